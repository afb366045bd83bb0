/*
 * param_wire.h - the guard in front of lcm-gen's param_request_t decoder.
 *
 * lcm-gen's C decoder allocates a request's keys and values from the count n as it arrives (a
 * negative or huge n asks malloc for that much) and leaks what it has allocated when a string
 * further on is cut short. A request comes from anyone on the bus, so its bytes are walked once
 * against the wire layout before the generated decoder sees them; the decoding itself is lcm-gen's.
 */
#ifndef OMNI4_PARAM_WIRE_H
#define OMNI4_PARAM_WIRE_H

#include <stdbool.h>
#include <stddef.h>

/* True if data[0..len) is one complete param_request_t with nothing after it and its n within
 * 0..max_n; otherwise false with what is wrong in why. */
bool param_request_wire_ok(const void *data, size_t len, int max_n, char *why, size_t n_why);

#endif /* OMNI4_PARAM_WIRE_H */
