// Reads an MCAP file with the TypeScript MCAP library (@mcap/core, not written by this project):
// once indexed (summary + chunk indexes, chunk CRCs validated) and once streamed from the first
// byte (every record parsed, CRCs validated), and prints every message of the indexed read as a
// JSON line {"topic", "schema", "encoding", "log_time", "msg"} followed by one summary line
// {"summary": {"indexed": {topic: count}, "streamed": {topic: count}, "statistics": {...}}}.
// Usage: node read_mcap.mjs FILE.mcap > OUT.jsonl   (exit 1 with one line on any error)
//        node read_mcap.mjs --summary FILE.mcap       (the same reads and checks, only the summary)
import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import { FileHandleReadable } from "@mcap/nodejs";
import { loadDecompressHandlers } from "@mcap/support";
import { open, readFile } from "fs/promises";

async function main(args) {
  const summaryOnly = args[0] === "--summary";
  const path = summaryOnly ? args[1] : args[0];
  if (!path) throw new Error("usage: node read_mcap.mjs [--summary] FILE.mcap");
  const decompressHandlers = await loadDecompressHandlers();
  const fh = await open(path, "r");
  const reader = await McapIndexedReader.Initialize({
    readable: new FileHandleReadable(fh),
    decompressHandlers,
  });
  const dec = new TextDecoder();
  const indexed = {};
  const out = [];
  for await (const m of reader.readMessages({ validateCrcs: true })) {
    const ch = reader.channelsById.get(m.channelId);
    const schema = reader.schemasById.get(ch.schemaId);
    indexed[ch.topic] = (indexed[ch.topic] ?? 0) + 1;
    const msg = JSON.parse(dec.decode(m.data)); // every payload is JSON, summary or not
    if (summaryOnly) continue;
    out.push(JSON.stringify({
      topic: ch.topic, schema: schema?.name ?? "", encoding: ch.messageEncoding,
      log_time: m.logTime.toString(), msg,
    }));
    if (out.length >= 10000) { process.stdout.write(out.join("\n") + "\n"); out.length = 0; }
  }
  if (out.length) process.stdout.write(out.join("\n") + "\n");
  await fh.close();

  const stream = new McapStreamReader({ decompressHandlers, validateCrcs: true });
  stream.append(await readFile(path));
  const topics = new Map();
  const streamed = {};
  let footer = false;
  for (let r; (r = stream.nextRecord()); ) {
    if (r.type === "Channel") topics.set(r.id, r.topic);
    else if (r.type === "Message") {
      const t = topics.get(r.channelId);
      streamed[t] = (streamed[t] ?? 0) + 1;
    } else if (r.type === "Footer") footer = true;
  }
  if (!stream.done() || !footer) throw new Error("stream read did not reach the footer");
  const st = reader.statistics;
  const statistics = st ? {
    messageCount: Number(st.messageCount), chunkCount: st.chunkCount,
    channelCount: st.channelCount,
  } : null;
  const compression = [...new Set(reader.chunkIndexes.map((c) => c.compression))];
  process.stdout.write(JSON.stringify({ summary: { indexed, streamed, statistics, compression } }) + "\n");
}

main(process.argv.slice(2)).catch((e) => {
  console.error(`read_mcap.mjs: ${e.message ?? e}`);
  process.exit(1);
});
