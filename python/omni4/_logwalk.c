/*
 * _logwalk.c - the header walk of omni4.read_log in C: the intact events of an LCM event log
 * held in memory, found as host-tools/common/logdata.cpp finds them (and as log.py's numpy
 * walk, _walk_numpy, does: the tests compare the two). From the start, an event whose header
 * is valid (sync word 0xEDA1DA01, 0 < channel length <= max_channel, data length >= 0, the whole
 * event inside the buffer) is taken and the walk continues after it; anything else moves the
 * walk to the next sync word. One pass that jumps from event to event; bytes are scanned only
 * where there is no event.
 *
 * Built by python/setup.py into a plain shared library that log.py loads with ctypes (no
 * Python API here).
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#define SYNC0 0xEDu
#define HEADER 28

static uint32_t be32(const uint8_t *p)
{
	return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | (uint32_t)p[3];
}

static int64_t be64(const uint8_t *p)
{
	return (int64_t)((uint64_t)be32(p) << 32 | be32(p + 4));
}

/* The next sync word at or after pos (n if none). */
static size_t next_sync(const uint8_t *buf, size_t n, size_t pos)
{
	while (pos + 4 <= n) {
		const uint8_t *hit = memchr(buf + pos, SYNC0, n - 3 - pos);

		if (!hit)
			return n;
		pos = (size_t)(hit - buf);
		if (be32(hit) == 0xEDA1DA01u)
			return pos;
		pos++;
	}
	return n;
}

/*
 * Walks buf[0, n). For each intact event (at most cap): its offset, channel length, data length
 * and log time. Returns the number of intact events (which may exceed cap: call again with a
 * larger cap); *used is the bytes inside them, *tail the bytes after the last one (n if none).
 */
size_t omni4_log_walk(const uint8_t *buf, size_t n, int64_t max_channel, size_t cap,
                      int64_t *off, int64_t *clen, int64_t *dlen, int64_t *utime, int64_t *used,
                      int64_t *tail)
{
	size_t k = 0, pos = next_sync(buf, n, 0), end = 0;

	*used = 0;
	while (pos + HEADER <= n) {
		const int64_t c = (int32_t)be32(buf + pos + 20), d = (int32_t)be32(buf + pos + 24);
		const int64_t len = HEADER + c + d;

		if (c > 0 && c <= max_channel && d >= 0 && (uint64_t)len <= n - pos) {
			if (k < cap) {
				off[k] = (int64_t)pos;
				clen[k] = c;
				dlen[k] = d;
				utime[k] = be64(buf + pos + 12);
			}
			k++;
			*used += len;
			pos += (size_t)len;
			end = pos;
			if (pos + 4 <= n && be32(buf + pos) == 0xEDA1DA01u)
				continue;
		} else {
			pos++;
		}
		pos = next_sync(buf, n, pos);
	}
	*tail = (int64_t)(n - end);
	return k;
}

/*
 * The channel of each of the k events at off (channel lengths clen) as an index into the n_names
 * names packed in names (name i: name_len[i] bytes at name_off[i]), or -1 for another name:
 * equal length and equal bytes.
 */
void omni4_log_channel_ids(const uint8_t *buf, size_t k, const int64_t *off, const int64_t *clen,
                           const uint8_t *names, const int64_t *name_off,
                           const int64_t *name_len, size_t n_names, int64_t *ids)
{
	int64_t last = -1; /* the previous event's name: logs interleave few channels */

	for (size_t e = 0; e < k; e++) {
		const uint8_t *ch = buf + off[e] + HEADER;
		int64_t id = -1;

		if (last >= 0 && name_len[last] == clen[e] &&
		    !memcmp(ch, names + name_off[last], (size_t)clen[e]))
			id = last;
		for (size_t i = 0; id < 0 && i < n_names; i++)
			if (name_len[i] == clen[e] && !memcmp(ch, names + name_off[i], (size_t)clen[e]))
				id = (int64_t)i;
		ids[e] = id;
		if (id >= 0)
			last = id;
	}
}

/* The k payloads at doff, each size bytes, one after another into out (k * size bytes). */
void omni4_log_gather(const uint8_t *buf, size_t k, const int64_t *doff, size_t size, uint8_t *out)
{
	for (size_t e = 0; e < k; e++)
		memcpy(out + e * size, buf + doff[e], size);
}
