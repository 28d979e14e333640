// SPDX-License-Identifier: Apache-2.0
//
// Reads an MCAP file with the format's reference reader (@mcap/core) and
// prints one JSON document describing it on stdout. Messages whose channel
// uses message encoding "cdr" with an "omgidl" schema are decoded with
// @foxglove/omgidl-parser and @foxglove/omgidl-serialization.
//
// Usage: node read.mjs FILE [--stream] [--raw] [--start NS] [--end NS]
//
//   (default)    McapIndexedReader: needs a valid footer, summary and chunk
//                indexes (it finds messages through chunk indexes only, so
//                statistics with messages but no chunk index fail); messages
//                come in log-time order. Also checks the summary CRC and the
//                data section CRC (when not zero).
//   --stream     McapStreamReader (chunk CRCs validated): every record in
//                file order; fails unless the reader reaches the footer
//                (done()). Also checks the summary and data section CRCs.
//   --start NS   only messages with logTime >= NS (nanoseconds)
//   --end NS     only messages with logTime <= NS
//   --raw        do not decode: "data" is the hex string of the raw bytes
//
// Exit status 0 on success; 1 with "read.mjs: <what failed>: <message>" on
// stderr for any reader, CRC or decoding error; 2 for a usage error.

import { open } from "node:fs/promises";

import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import { loadDecompressHandlers } from "@mcap/support";
import * as crcModule from "@foxglove/crc";
import * as idlParserModule from "@foxglove/omgidl-parser";
import * as idlSerializationModule from "@foxglove/omgidl-serialization";

// Some of these packages are CommonJS; depending on the Node version their
// names are visible as named exports or only on the default export.
function pick(mod, name) {
  const value = mod[name] ?? mod.default?.[name];
  if (value === undefined) {
    throw new Error(`export ${name} not found`);
  }
  return value;
}
const crc32 = pick(crcModule, "crc32");
const parseIDL = pick(idlParserModule, "parseIDL");
const MessageReader = pick(idlSerializationModule, "MessageReader");

class Failure extends Error {
  constructor(what, cause) {
    super(cause instanceof Error ? cause.message : String(cause));
    this.what = what;
  }
}

function fail(what, cause) {
  throw new Failure(what, cause);
}

async function step(what, fn) {
  try {
    return await fn();
  } catch (err) {
    if (err instanceof Failure) {
      throw err;
    }
    throw new Failure(what, err);
  }
}

const USAGE = "usage: node read.mjs FILE [--stream] [--raw] [--start NS] [--end NS]";

function parseArgs(argv) {
  const opts = { file: undefined, stream: false, raw: false, start: undefined, end: undefined };
  const parseNs = (flag, text) => {
    if (text === undefined || !/^[0-9]+$/.test(text)) {
      throw new Error(`${flag} needs a non-negative integer (nanoseconds), got ${text ?? "nothing"}`);
    }
    return BigInt(text);
  };
  for (let i = 0; i < argv.length; i++) {
    const arg = argv[i];
    if (arg === "--stream") {
      opts.stream = true;
    } else if (arg === "--raw") {
      opts.raw = true;
    } else if (arg === "--start") {
      opts.start = parseNs(arg, argv[++i]);
    } else if (arg === "--end") {
      opts.end = parseNs(arg, argv[++i]);
    } else if (arg.startsWith("--")) {
      throw new Error(`unknown option ${arg}`);
    } else if (opts.file === undefined) {
      opts.file = arg;
    } else {
      throw new Error(`unexpected argument ${arg}`);
    }
  }
  if (opts.file === undefined) {
    throw new Error("no FILE given");
  }
  return opts;
}

// ---- JSON conversion -------------------------------------------------------

function hex(bytes) {
  return Buffer.from(bytes.buffer, bytes.byteOffset, bytes.byteLength).toString("hex");
}

function plainNumber(n) {
  if (Number.isNaN(n)) return "NaN";
  if (n === Infinity) return "Infinity";
  if (n === -Infinity) return "-Infinity";
  return n;
}

// Turns a decoded message into plain JSON values: bigint -> decimal string,
// typed arrays -> arrays, NaN/Infinity -> strings.
function toPlain(value) {
  if (typeof value === "bigint") return value.toString();
  if (typeof value === "number") return plainNumber(value);
  if (value === null || typeof value !== "object") return value;
  if (ArrayBuffer.isView(value) && !(value instanceof DataView)) {
    return Array.from(value, toPlain);
  }
  if (Array.isArray(value)) return value.map(toPlain);
  if (value instanceof Map) {
    const out = {};
    for (const [k, v] of value) out[String(k)] = toPlain(v);
    return out;
  }
  const out = {};
  for (const [k, v] of Object.entries(value)) out[k] = toPlain(v);
  return out;
}

function mapToObject(map) {
  const out = {};
  for (const [k, v] of map) out[String(k)] = typeof v === "bigint" ? v.toString() : v;
  return out;
}

function schemaJson(s) {
  return { id: s.id, name: s.name, encoding: s.encoding };
}

function channelJson(c) {
  return {
    id: c.id,
    topic: c.topic,
    schemaId: c.schemaId,
    messageEncoding: c.messageEncoding,
    metadata: mapToObject(c.metadata),
  };
}

function statisticsJson(s) {
  if (s === undefined) return null;
  return {
    messageCount: s.messageCount.toString(),
    schemaCount: s.schemaCount,
    channelCount: s.channelCount,
    attachmentCount: s.attachmentCount,
    metadataCount: s.metadataCount,
    chunkCount: s.chunkCount,
    messageStartTime: s.messageStartTime.toString(),
    messageEndTime: s.messageEndTime.toString(),
    channelMessageCounts: mapToObject(s.channelMessageCounts),
  };
}

function metadataJson(m) {
  return { name: m.name, metadata: mapToObject(m.metadata) };
}

// ---- decoding --------------------------------------------------------------

class Decoders {
  // `where` tells where channel and schema records must have been seen.
  constructor(raw, where) {
    this.raw = raw;
    this.where = where;
    this.schemas = new Map(); // id -> Schema record
    this.channels = new Map(); // id -> Channel record
    this.readersBySchema = new Map(); // schema id -> MessageReader
  }

  addSchema(schema) {
    this.schemas.set(schema.id, schema);
  }

  // Builds the decoder for a channel as soon as the channel is known, so a
  // schema the parser rejects fails even when no message uses it.
  addChannel(channel) {
    this.channels.set(channel.id, channel);
    this.readerFor(channel);
  }

  readerFor(channel) {
    if (this.raw || channel.messageEncoding !== "cdr" || channel.schemaId === 0) {
      return undefined;
    }
    const schema = this.schemas.get(channel.schemaId);
    if (schema === undefined) {
      fail(
        `channel ${channel.id} (${channel.topic})`,
        `unknown schema id ${channel.schemaId} (none ${this.where})`,
      );
    }
    if (schema.encoding !== "omgidl") {
      return undefined;
    }
    let reader = this.readersBySchema.get(schema.id);
    if (reader === undefined) {
      const what = `schema ${schema.id} (${schema.name})`;
      let text;
      try {
        text = new TextDecoder("utf-8", { fatal: true }).decode(schema.data);
      } catch (err) {
        fail(`${what}: schema data is not UTF-8`, err);
      }
      let definitions;
      try {
        definitions = parseIDL(text);
      } catch (err) {
        fail(`${what}: parseIDL`, err);
      }
      try {
        reader = new MessageReader(schema.name, definitions);
      } catch (err) {
        fail(`${what}: MessageReader`, err);
      }
      this.readersBySchema.set(schema.id, reader);
    }
    return reader;
  }

  messageJson(message) {
    const channel = this.channels.get(message.channelId);
    if (channel === undefined) {
      fail(
        `message at logTime ${message.logTime}`,
        `unknown channel id ${message.channelId} (none ${this.where})`,
      );
    }
    const reader = this.readerFor(channel);
    let data;
    if (reader === undefined) {
      data = hex(message.data);
    } else {
      try {
        data = toPlain(reader.readMessage(message.data));
      } catch (err) {
        fail(
          `decoding message on channel ${channel.id} (${channel.topic}) ` +
            `sequence ${message.sequence} logTime ${message.logTime}`,
          err,
        );
      }
    }
    return {
      channelId: message.channelId,
      topic: channel.topic,
      sequence: message.sequence,
      logTime: message.logTime.toString(),
      publishTime: message.publishTime.toString(),
      data,
    };
  }
}

function inRange(opts, logTime) {
  return (
    (opts.start === undefined || logTime >= opts.start) &&
    (opts.end === undefined || logTime <= opts.end)
  );
}

// ---- indexed mode ----------------------------------------------------------

class FileReadable {
  constructor(handle) {
    this.handle = handle;
  }

  async size() {
    const stat = await this.handle.stat();
    return BigInt(stat.size);
  }

  async read(offset, length) {
    const len = Number(length);
    const pos = Number(offset);
    const buffer = new Uint8Array(len);
    let done = 0;
    while (done < len) {
      const { bytesRead } = await this.handle.read(buffer, done, len - done, pos + done);
      if (bytesRead === 0) {
        throw new Error(`short read: wanted ${len} bytes at offset ${pos}, file ended after ${done}`);
      }
      done += bytesRead;
    }
    return buffer;
  }
}

async function readIndexed(opts, handle, decompressHandlers) {
  const readable = new FileReadable(handle);
  const reader = await step("reading header, footer and summary (indexed reader)", () =>
    McapIndexedReader.Initialize({ readable, decompressHandlers }),
  );
  if (reader.footer.summaryStart === 0n) {
    fail("reading summary (indexed reader)", "file has no summary section");
  }

  if (reader.chunkIndexes.length === 0 && (reader.statistics?.messageCount ?? 0n) > 0n) {
    // The indexed reader finds messages through chunk indexes only.
    fail(
      "reading summary (indexed reader)",
      `statistics count ${reader.statistics.messageCount} messages but there is no chunk index`,
    );
  }

  if (reader.dataSectionCrc !== undefined) {
    await step("checking data section CRC", async () => {
      const bytes = await readable.read(0n, reader.dataEndOffset);
      const actual = crc32(bytes);
      if (actual !== reader.dataSectionCrc) {
        throw new Error(`Incorrect data section CRC ${actual} (expected ${reader.dataSectionCrc})`);
      }
    });
  }

  const decoders = new Decoders(opts.raw, "in the summary section");
  const schemas = [...reader.schemasById.values()].sort((a, b) => a.id - b.id);
  const channels = [...reader.channelsById.values()].sort((a, b) => a.id - b.id);
  await step("preparing decoders", () => {
    for (const schema of schemas) decoders.addSchema(schema);
    for (const channel of channels) decoders.addChannel(channel);
  });

  const metadata = [];
  await step("reading metadata", async () => {
    for await (const record of reader.readMetadata()) metadata.push(metadataJson(record));
  });

  const messages = [];
  const range = { validateCrcs: true };
  if (opts.start !== undefined) range.startTime = opts.start;
  if (opts.end !== undefined) range.endTime = opts.end;
  await step("reading messages (indexed reader)", async () => {
    for await (const message of reader.readMessages(range)) {
      messages.push(decoders.messageJson(message));
    }
  });

  return {
    header: { profile: reader.header.profile, library: reader.header.library },
    schemas: schemas.map(schemaJson),
    channels: channels.map(channelJson),
    statistics: statisticsJson(reader.statistics),
    metadata,
    chunkIndexes: reader.chunkIndexes.length,
    messages,
  };
}

// ---- stream mode -----------------------------------------------------------

const MAGIC_LENGTH = 8n;
const FOOTER_RECORD_LENGTH = 1n + 8n + 8n + 8n + 4n;
const DATA_END_RECORD_LENGTH = 1n + 8n + 4n;
const DATA_END_OPCODE = 0x0f;

// The stream reader checks chunk CRCs only; check the summary CRC and the
// data section CRC (when not zero) like a reader of the whole file would.
async function checkStreamCrcs(readable, size, footer, dataEnd) {
  const footerOffset = size - MAGIC_LENGTH - FOOTER_RECORD_LENGTH;
  if (footer.summaryStart !== 0n && footer.summaryCrc !== 0) {
    await step("checking summary CRC", async () => {
      const bytes = await readable.read(
        footer.summaryStart,
        size - MAGIC_LENGTH - 4n - footer.summaryStart,
      );
      const actual = crc32(bytes);
      if (actual !== footer.summaryCrc) {
        throw new Error(`Incorrect summary CRC ${actual} (expected ${footer.summaryCrc})`);
      }
    });
  }
  if (dataEnd !== undefined && dataEnd.dataSectionCrc !== 0) {
    await step("checking data section CRC", async () => {
      const end = footer.summaryStart !== 0n ? footer.summaryStart : footerOffset;
      const dataEndOffset = end - DATA_END_RECORD_LENGTH;
      const opcode = await readable.read(dataEndOffset, 1n);
      if (opcode[0] !== DATA_END_OPCODE) {
        throw new Error(`no DataEnd record of ${DATA_END_RECORD_LENGTH} bytes right before offset ${end}`);
      }
      const actual = crc32(await readable.read(0n, dataEndOffset));
      if (actual !== dataEnd.dataSectionCrc) {
        throw new Error(`Incorrect data section CRC ${actual} (expected ${dataEnd.dataSectionCrc})`);
      }
    });
  }
}

async function readStream(opts, handle, decompressHandlers) {
  const reader = new McapStreamReader({ decompressHandlers, validateCrcs: true, includeChunks: true });
  const decoders = new Decoders(opts.raw, "earlier in the file");
  const out = {
    header: null,
    schemas: [],
    channels: [],
    statistics: null,
    metadata: [],
    chunkIndexes: 0,
    messages: [],
    recordCounts: {},
  };
  let footer;
  let dataEnd;
  const seenSchemas = new Set();
  const seenChannels = new Set();

  const take = (record) => {
    out.recordCounts[record.type] = (out.recordCounts[record.type] ?? 0) + 1;
    switch (record.type) {
      case "Header":
        out.header = { profile: record.profile, library: record.library };
        break;
      case "Schema":
        decoders.addSchema(record);
        if (!seenSchemas.has(record.id)) {
          seenSchemas.add(record.id);
          out.schemas.push(schemaJson(record));
        }
        break;
      case "Channel":
        decoders.addChannel(record);
        if (!seenChannels.has(record.id)) {
          seenChannels.add(record.id);
          out.channels.push(channelJson(record));
        }
        break;
      case "Message":
        if (inRange(opts, record.logTime)) out.messages.push(decoders.messageJson(record));
        break;
      case "Metadata":
        out.metadata.push(metadataJson(record));
        break;
      case "Statistics":
        out.statistics = statisticsJson(record);
        break;
      case "ChunkIndex":
        out.chunkIndexes += 1;
        break;
      case "Footer":
        footer = record;
        break;
      case "DataEnd":
        dataEnd = record;
        break;
      default:
        break;
    }
  };

  const stat = await handle.stat();
  const blockSize = 1 << 20;
  let position = 0;
  await step("reading records (stream reader)", async () => {
    while (position < stat.size) {
      const block = new Uint8Array(Math.min(blockSize, stat.size - position));
      const { bytesRead } = await handle.read(block, 0, block.length, position);
      if (bytesRead === 0) break;
      position += bytesRead;
      reader.append(block.subarray(0, bytesRead));
      for (let record; (record = reader.nextRecord()); ) take(record);
    }
  });
  if (!reader.done()) {
    fail(
      "reading records (stream reader)",
      `stream ended before a valid footer and closing magic ` +
        `(${reader.bytesRemaining()} of ${stat.size} bytes not parsed)`,
    );
  }
  await checkStreamCrcs(new FileReadable(handle), BigInt(stat.size), footer, dataEnd);
  if (footer !== undefined && footer.summaryStart === 0n) {
    out.chunkIndexes = null;
  }
  out.schemas.sort((a, b) => a.id - b.id);
  out.channels.sort((a, b) => a.id - b.id);
  return out;
}

// ---- main ------------------------------------------------------------------

async function main() {
  let opts;
  try {
    opts = parseArgs(process.argv.slice(2));
  } catch (err) {
    process.stderr.write(`read.mjs: ${err.message}\n${USAGE}\n`);
    return 2;
  }
  try {
    const decompressHandlers = await step("loading decompression handlers", () =>
      loadDecompressHandlers(),
    );
    const handle = await step(`opening ${opts.file}`, () => open(opts.file, "r"));
    let result;
    try {
      result = opts.stream
        ? await readStream(opts, handle, decompressHandlers)
        : await readIndexed(opts, handle, decompressHandlers);
    } finally {
      await handle.close();
    }
    const text = JSON.stringify(result) + "\n";
    await new Promise((resolve, reject) =>
      process.stdout.write(text, (err) => (err ? reject(err) : resolve())),
    );
    return 0;
  } catch (err) {
    const what = err instanceof Failure ? err.what : "unexpected error";
    process.stderr.write(`read.mjs: ${what}: ${err.message}\n`);
    return 1;
  }
}

process.exitCode = await main();
