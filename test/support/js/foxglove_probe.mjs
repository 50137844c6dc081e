// The official Foxglove WebSocket client (@foxglove/ws-protocol) against a server, for tests.
//
// usage: node foxglove_probe.mjs URL MESSAGES [SUBPROTOCOL]
//
// Connects with `ws` offering SUBPROTOCOL (default FoxgloveClient.SUPPORTED_SUBPROTOCOL,
// "foxglove.websocket.v1", as the Foxglove app's older releases and Lichtblick do), subscribes
// to every channel advertised, and prints one JSON line per event: {"event": "open",
// "protocol"}, {"event": "serverInfo", "name"}, {"event": "advertise", "topics"},
// {"event": "message", "topic", "hex"}; after MESSAGES messages it prints {"event": "done"}
// and closes (MESSAGES 0: after the first advertise). A refused handshake or an error prints {"event": "error", "message"}, exit 1.
import protocol_package from "@foxglove/ws-protocol"; // (a CommonJS package: no named ESM exports)
import WebSocket from "ws";

const { FoxgloveClient } = protocol_package;

const [url, wanted, subprotocol] = process.argv.slice(2);
const protocol = subprotocol ?? FoxgloveClient.SUPPORTED_SUBPROTOCOL;
const say = (event) => process.stdout.write(JSON.stringify(event) + "\n");
const ws = new WebSocket(url, [protocol]);
const client = new FoxgloveClient({ ws });
const topics = new Map();
let received = 0;

client.on("open", () => say({ event: "open", protocol: ws.protocol }));
client.on("serverInfo", (info) => say({ event: "serverInfo", name: info.name }));
client.on("advertise", (channels) => {
  say({ event: "advertise", topics: channels.map((c) => c.topic) });
  for (const channel of channels) {
    topics.set(client.subscribe(channel.id), channel.topic);
  }
  if (Number(wanted) === 0) {
    say({ event: "done" });
    client.close();
  }
});
client.on("message", ({ subscriptionId, data }) => {
  const hex = Buffer.from(data.buffer, data.byteOffset, data.byteLength).toString("hex");
  say({ event: "message", topic: topics.get(subscriptionId), hex });
  received += 1;
  if (received >= Number(wanted)) {
    say({ event: "done" });
    client.close();
  }
});
client.on("error", (error) => {
  say({ event: "error", message: String(error?.message ?? error) });
  process.exit(1);
});
client.on("close", () => process.exit(received >= Number(wanted) ? 0 : 1));
