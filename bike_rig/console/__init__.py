"""The operator's terminal console (textual) over the session controller."""
