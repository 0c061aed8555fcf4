"""Structural check of MCAP files before their messages are trusted.

A rosbag2 MCAP file stores each fact about its messages more than once: every
message's log time is in its record, in its chunk's time range, in the chunk's
message index, in the chunk index and in the statistics of the summary section;
channels and schemas are repeated in the summary. ``check_mcap`` walks the file
[1] and refuses it when any copy disagrees, when a record runs past the end, or
when a CRC the writer stored does not match. Writers that store no CRCs (rosbags
does not) leave message payloads without a second copy: a flipped byte inside a
value is then caught only when the value leaves its allowed range.

References
----------
[1] Foxglove, "MCAP file format specification", version 0x30 ("0"),
    https://mcap.dev/spec (records, opcodes and field layouts used here).
"""
import mmap
import os
import struct
import zlib

MAGIC = b'\x89MCAP0\r\n'
HEADER, FOOTER, SCHEMA, CHANNEL, MESSAGE, CHUNK, MESSAGE_INDEX, CHUNK_INDEX = range(1, 9)
ATTACHMENT, ATTACHMENT_INDEX, STATISTICS, METADATA, METADATA_INDEX = range(9, 14)
SUMMARY_OFFSET, DATA_END = 0x0E, 0x0F
PRIVATE_OPCODES = 0x80  # opcodes from here on are application records, skipped by spec
MAX_CHUNK_BYTES = 1 << 30  # rosbag2 writes chunks of about 4 MB; a larger claim is a flip
FOOTER_LENGTH = 20  # u64 summary_start, u64 summary_offset_start, u32 summary_crc


class BagCorrupt(ValueError):
    """An MCAP file is not intact; ``offset`` is the byte where the check failed."""

    def __init__(self, offset, text):
        super().__init__(f'byte {offset}: {text}')
        self.offset = offset


def check_mcap(path):
    """Raise BagCorrupt unless the MCAP file at ``path`` is structurally intact.

    Checks the magic bytes, every record's length, the stored CRCs (chunk, data
    section, summary), each chunk's time range against its messages, the message
    indexes, the chunk indexes, the statistics and the summary's copies of the
    schemas and channels. The file is memory-mapped, not read into memory.
    """
    with open(path, 'rb') as fh:
        size = os.fstat(fh.fileno()).st_size
        if size < 2 * len(MAGIC) + 9 + FOOTER_LENGTH:
            raise BagCorrupt(0, f'{size} bytes is too short for an MCAP file')
        with mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as buf:
            try:
                _Checker(buf, size).run()
            except (struct.error, IndexError, UnicodeDecodeError) as exc:
                raise BagCorrupt(size, f'a field runs past its record ({exc})') from None


class _Checker:
    """One pass over an MCAP file's records (see ``check_mcap``)."""

    def __init__(self, buf, size):
        self.buf, self.size = buf, size
        self.channels, self.schemas = {}, {}  # id -> record content (bytes)
        self.chunks = {}  # record offset -> (start, end, uncompressed size, record length)
        self.counts = {}  # channel id -> messages
        self.times = []  # (min, max) log time of each chunk or lone message
        self.n_messages = 0

    def u(self, fmt, offset):
        return struct.unpack_from('<' + fmt, self.buf, offset)

    def records(self, data, start, end, base=0):
        """Yield (offset, opcode, content start, length) of the records in data[start:end]."""
        pos = start
        while pos < end:
            if pos + 9 > end:
                raise BagCorrupt(base + pos, 'a record header runs past its section')
            op = data[pos]
            (length,) = struct.unpack_from('<Q', data, pos + 1)
            if length > end - pos - 9:
                raise BagCorrupt(base + pos, f'record 0x{op:02x} of {length} bytes runs past '
                                             'its section')
            if op == 0 or (op > DATA_END and op < PRIVATE_OPCODES):
                raise BagCorrupt(base + pos, f'unknown record opcode 0x{op:02x}')
            yield pos, op, pos + 9, length
            pos += 9 + length

    def run(self):
        buf, size = self.buf, self.size
        if buf[:len(MAGIC)] != MAGIC:
            raise BagCorrupt(0, 'no MCAP magic at the start')
        if buf[size - len(MAGIC):] != MAGIC:
            raise BagCorrupt(size - len(MAGIC), 'no MCAP magic at the end (truncated?)')
        recs = list(self.records(buf, len(MAGIC), size - len(MAGIC)))
        if not recs or recs[0][1] != HEADER:
            raise BagCorrupt(len(MAGIC), 'the first record is not the header')
        footer = recs[-1]
        if footer[1] != FOOTER or footer[3] != FOOTER_LENGTH:
            raise BagCorrupt(footer[0], 'the last record is not a 20-byte footer')
        ends = [i for i, r in enumerate(recs) if r[1] == DATA_END]
        if len(ends) != 1:
            raise BagCorrupt(footer[0], f'{len(ends)} data-end records, expected 1')
        data_end = ends[0]
        self.data_section(recs[:data_end])
        pos, _, c0, _ = recs[data_end]
        (crc,) = self.u('I', c0)
        if crc and zlib.crc32(buf[:pos]) != crc:
            raise BagCorrupt(pos, 'data section CRC mismatch')
        self.summary(recs[data_end + 1:-1], recs[data_end][0] + 9 + recs[data_end][3], footer)

    def data_section(self, recs):
        positions = {r[0]: r[1] for r in recs}
        self.positions = positions
        i = 0
        while i < len(recs):
            pos, op, c0, length = recs[i]
            i += 1
            if op == CHUNK:
                entries = self.chunk(pos, c0, length)
                indexed = {}
                while i < len(recs) and recs[i][1] == MESSAGE_INDEX:
                    ipos, _, i0, ilen = recs[i]
                    channel, pairs = self.message_index(i0, ilen)
                    if channel in indexed:
                        raise BagCorrupt(ipos, f'channel {channel} indexed twice for one chunk')
                    indexed[channel] = (ipos, pairs)
                    i += 1
                if indexed:
                    for channel in set(entries) | set(indexed):
                        ipos, pairs = indexed.get(channel, (pos, []))
                        if sorted(pairs) != sorted(entries.get(channel, [])):
                            raise BagCorrupt(ipos, f'message index of channel {channel} does '
                                                   "not match the chunk's messages")
            elif op in (SCHEMA, CHANNEL):
                self.definition(self.buf, op, c0, length, pos)
            elif op == MESSAGE:
                (channel, _, log_time) = self.u('HIQ', c0)
                self.message(channel, log_time, pos)
                self.times.append((log_time, log_time))
            elif op == MESSAGE_INDEX:
                raise BagCorrupt(pos, 'a message index that follows no chunk')

    def definition(self, data, op, c0, length, pos):
        (key,) = struct.unpack_from('<H', data, c0)
        table = self.schemas if op == SCHEMA else self.channels
        content = bytes(data[c0:c0 + length])
        if table.get(key, content) != content:
            raise BagCorrupt(pos, f'{"schema" if op == SCHEMA else "channel"} {key} defined '
                                  'twice, differently')
        table[key] = content

    def message(self, channel, log_time, pos):
        if channel not in self.channels:
            raise BagCorrupt(pos, f'message on undefined channel {channel}')
        self.counts[channel] = self.counts.get(channel, 0) + 1
        self.n_messages += 1

    def chunk(self, pos, c0, length):
        start, end, usize, ucrc = self.u('QQQI', c0)
        (clen,) = self.u('I', c0 + 28)
        compression = bytes(self.buf[c0 + 32:c0 + 32 + clen]).decode('utf-8')
        (rlen,) = self.u('Q', c0 + 32 + clen)
        r0 = c0 + 40 + clen
        if r0 + rlen != c0 + length:
            raise BagCorrupt(pos, 'chunk records do not fill the chunk')
        if usize > MAX_CHUNK_BYTES:
            raise BagCorrupt(pos, f'chunk claims {usize} uncompressed bytes (limit '
                                  f'{MAX_CHUNK_BYTES})')
        raw = _decompress(compression, self.buf[r0:r0 + rlen], usize, pos)
        if raw is None:  # compression this interpreter cannot undo: CRC unchecked
            self.chunks[pos] = (start, end, usize, length)
            self.times.append((start, end))
            return {}
        if len(raw) != usize:
            raise BagCorrupt(pos, f'chunk holds {len(raw)} bytes, its header says {usize}')
        if ucrc and zlib.crc32(raw) != ucrc:
            raise BagCorrupt(pos, 'chunk CRC mismatch')
        entries, times = {}, []
        for ipos, op, i0, ilen in self.records(raw, 0, len(raw), base=r0):
            if op in (SCHEMA, CHANNEL):
                self.definition(raw, op, i0, ilen, r0 + ipos)
            elif op == MESSAGE:
                channel, _, log_time = struct.unpack_from('<HIQ', raw, i0)
                self.message(channel, log_time, r0 + ipos)
                entries.setdefault(channel, []).append((log_time, ipos))
                times.append(log_time)
            else:
                raise BagCorrupt(r0 + ipos, f'record 0x{op:02x} does not belong in a chunk')
        if times and (min(times), max(times)) != (start, end):
            raise BagCorrupt(pos, f'chunk time range {start}..{end} ns does not match its '
                                  f'messages ({min(times)}..{max(times)} ns)')
        self.chunks[pos] = (start, end, usize, length)
        self.times.append((start, end) if times else None)
        return entries

    def message_index(self, c0, length):
        (channel, nbytes) = self.u('HI', c0)
        if nbytes % 16 or 6 + nbytes != length:
            raise BagCorrupt(c0 - 9, 'message index length does not match its entries')
        pairs = [self.u('QQ', c0 + 6 + 16 * k) for k in range(nbytes // 16)]
        return channel, pairs

    def summary(self, recs, summary_pos, footer):
        fpos, _, f0, _ = footer
        start, offset_start, crc = self.u('QQI', f0)
        if start and (start != summary_pos or not recs):
            raise BagCorrupt(fpos, f'footer summary_start {start} is not the summary section '
                                   f'({summary_pos})')
        if crc and zlib.crc32(self.buf[start:f0 + 16]) != crc:
            raise BagCorrupt(fpos, 'summary section CRC mismatch')
        positions = {r[0]: r[1] for r in recs}
        if offset_start and positions.get(offset_start) != SUMMARY_OFFSET:
            raise BagCorrupt(fpos, f'footer summary_offset_start {offset_start} is not a '
                                   'summary offset record')
        times = [t for t in self.times if t]
        for pos, op, c0, length in recs:
            if op in (SCHEMA, CHANNEL):
                (key,) = self.u('H', c0)
                table = self.schemas if op == SCHEMA else self.channels
                if table.get(key) != bytes(self.buf[c0:c0 + length]):
                    raise BagCorrupt(pos, f'summary {"schema" if op == SCHEMA else "channel"} '
                                          f'{key} differs from the data section')
            elif op == STATISTICS:
                self.statistics(pos, c0, times)
            elif op == CHUNK_INDEX:
                t0, t1, cpos, clen = self.u('QQQQ', c0)
                if cpos not in self.chunks or self.chunks[cpos][0:2] != (t0, t1) or \
                        self.chunks[cpos][3] + 9 != clen:
                    raise BagCorrupt(pos, f'chunk index entry ({cpos}, {t0}..{t1} ns) matches '
                                          'no chunk')
            elif op == SUMMARY_OFFSET:
                group_op, group_start = self.u('BQ', c0)
                if positions.get(group_start) != group_op:
                    raise BagCorrupt(pos, 'summary offset points at no record of its group')

    def statistics(self, pos, c0, times):
        n, _, n_channels, _, _, n_chunks, t0, t1, nbytes = self.u('QHIIIIQQI', c0)
        base = c0 + 8 + 2 + 4 * 4 + 16 + 4
        if nbytes % 10:
            raise BagCorrupt(pos, 'statistics channel counts are not whole entries')
        counts = dict(self.u('HQ', base + 10 * k) for k in range(nbytes // 10))
        lo = min(t[0] for t in times) if times else 0
        hi = max(t[1] for t in times) if times else 0
        found = (self.n_messages, len(self.channels), len(self.chunks), lo, hi, self.counts)
        stated = (n, n_channels, n_chunks, t0, t1, {k: v for k, v in counts.items() if v})
        if found != stated:
            raise BagCorrupt(pos, 'statistics (messages, channels, chunks, time range, '
                                  'counts per channel) do not match the data section')


def _decompress(compression, data, usize, pos):
    """Return the chunk's records uncompressed, or None when no codec is installed."""
    if compression == '':
        return bytes(data)
    try:
        if compression == 'zstd':
            import zstandard
            return zstandard.ZstdDecompressor().decompress(bytes(data), max_output_size=usize)
        if compression == 'lz4':
            import lz4.frame
            return lz4.frame.decompress(bytes(data))
    except ImportError:
        return None
    except Exception as exc:  # the codecs raise their own error types
        raise BagCorrupt(pos, f'chunk does not decompress ({type(exc).__name__})') from None
    raise BagCorrupt(pos, f'unknown chunk compression {compression[:20]!r}')
