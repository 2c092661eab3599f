'use strict';
// Reads an MCAP file with Foxglove's own reader (@mcap/core, vendored in ./vendor) and prints one
// JSON line per message: an independent check that the files plexus::mcap::Writer makes are valid
// MCAP and hold exactly what was written (tests/unit/proto/mcap_independent_reader_test.cpp).
// Usage: node read_mcap.js FILE
// CommonJS only: it runs on Debian 12's nodejs 18 as well as on later ones.

const crypto = require('crypto');
const fs = require('fs');
const path = require('path');

const vendor = path.join(__dirname, 'vendor', 'node_modules');
const { McapIndexedReader } = require(path.join(vendor, '@mcap', 'core'));
const fzstd = require(path.join(vendor, 'fzstd'));

// The "readable" McapIndexedReader asks for: the size, and bytes at an offset, read as needed
// rather than loading the whole file.
class FileReadable {
    constructor(fd) {
        this.fd = fd;
    }

    async size() {
        return BigInt(fs.fstatSync(this.fd).size);
    }

    async read(offset, length) {
        const buffer = new Uint8Array(Number(length));
        let done = 0;
        while (done < buffer.length) {
            const got = fs.readSync(this.fd, buffer, done, buffer.length - done, Number(offset) + done);
            if (got === 0) {
                throw new Error(`the file ends at ${Number(offset) + done}, inside a read`);
            }
            done += got;
        }
        return buffer;
    }
}

async function main() {
    const file = process.argv[2];
    if (!file) {
        process.stderr.write('usage: node read_mcap.js FILE\n');
        process.exit(2);
    }
    const fd = fs.openSync(file, 'r');
    const reader = await McapIndexedReader.Initialize({
        readable: new FileReadable(fd),
        decompressHandlers: {
            zstd: (data, size) => fzstd.decompress(data, new Uint8Array(Number(size))),
        },
    });
    for await (const message of reader.readMessages()) {
        const channel = reader.channelsById.get(message.channelId);
        const line = {
            topic: channel.topic,
            messageEncoding: channel.messageEncoding,
            metadata: Object.fromEntries(channel.metadata),
            channelId: message.channelId,
            sequence: message.sequence,
            logTime: message.logTime.toString(),
            publishTime: message.publishTime.toString(),
            length: message.data.byteLength,
            sha256: crypto.createHash('sha256').update(message.data).digest('hex'),
        };
        process.stdout.write(JSON.stringify(line) + '\n');
    }
    fs.closeSync(fd);
}

main().catch((error) => {
    process.stderr.write(`read_mcap.js: ${error && error.message ? error.message : error}\n`);
    process.exit(1);
});
