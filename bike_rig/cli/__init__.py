"""The ``bike-rig`` command: one module per subcommand; the only place that prints for users."""
