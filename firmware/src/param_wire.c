/* param_wire.c - the guard in front of lcm-gen's param_request_t decoder (see param_wire.h). */
#include "omni4/firmware/param_wire.h"

#include <stdint.h>
#include <stdio.h>

/* The wire layout of param_request_t (lcm-gen's encoding, big-endian): fingerprint, utime,
 * request_id, op, secret, n, keys[n], values[n], name, text; a string is an int32 length that
 * counts its terminating NUL, then the bytes and the NUL. Walked before decoding, because
 * lcm-gen's decoder allocates keys and values from n as sent (a negative or huge n) and leaks
 * what it allocated when it stops half way. True if the message is complete, exact and
 * n is within 0..max_n (more than PARAM_MAX_KEYS is refused later with its own reason). */
static bool take_string(const unsigned char *b, size_t len, size_t *pos)
{
	if (len - *pos < 4)
		return false;
	const uint32_t n = (uint32_t)b[*pos] << 24 | (uint32_t)b[*pos + 1] << 16 |
	                   (uint32_t)b[*pos + 2] << 8 | b[*pos + 3];

	*pos += 4;
	if (n < 1 || n > len - *pos || b[*pos + n - 1] != 0)
		return false;
	*pos += n;
	return true;
}

bool param_request_wire_ok(const void *data, size_t len, int max_n, char *why, size_t n_why)
{
	const unsigned char *b = data;
	size_t pos = 8 + 8 + 8 + 1; /* fingerprint, utime, request_id, op */

	if (len < pos || !take_string(b, len, &pos) || len - pos < 4) {
		snprintf(why, n_why, "incomplete before n");
		return false;
	}
	const int32_t n = (int32_t)((uint32_t)b[pos] << 24 | (uint32_t)b[pos + 1] << 16 |
	                            (uint32_t)b[pos + 2] << 8 | b[pos + 3]);

	pos += 4;
	if (n < 0 || n > max_n) {
		snprintf(why, n_why, "n = %d outside 0..%d", (int)n, max_n);
		return false;
	}
	for (int k = 0; k < 2 * n + 2; k++) { /* keys, values, name, text */
		if (!take_string(b, len, &pos)) {
			snprintf(why, n_why, "string %d of %d incomplete", k + 1, 2 * n + 2);
			return false;
		}
	}
	if (pos != len) {
		snprintf(why, n_why, "%zu bytes after the message", len - pos);
		return false;
	}
	return true;
}
