/*
 * can_proto.h - the omni4 motor-driver CAN protocol: pure encode/decode, no I/O.
 * Every frame is described in drivers/can/omni4.dbc (signals little-endian, start bit = LSB).
 *
 * Bus: classic CAN 2.0A (11-bit IDs), 1 Mbit/s. Two dual-channel driver boards: node 0 drives
 * channels 0 and 1, node 1 channels 2 and 3.
 *   0x010 CMD_VOLTAGE  controller -> drivers, every tick: 4 x 10-bit voltage (40 mV), enable
 *   0x011 CMD_CONTROL  controller -> drivers, on event: enable / disable / clear faults
 *   0x020+n STATUS     node n -> controller, every tick: 2 x 10-bit current (20 mA),
 *                      2 x 11-bit wheel speed (0.125 rad/s)
 *   0x030+n HEALTH     node n -> controller, 100 Hz (heartbeat): faults, supply, temperature
 * Every frame is 8 bytes, AUTOSAR E2E style: signals in bits 0-43 (unused bits reserved, must
 * be 0), a 4-bit rolling counter in bits 44-47, and in bytes 6-7 (little-endian) a CRC-16
 * (CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, no reflection, xor-out 0) over data bytes 0-5
 * followed by the frame's 16-bit data ID (low byte, high byte; not transmitted, 0x4F00 | CAN ID):
 * drops, replays, corruption and a frame of one ID taken for another all show.
 * Acceptance of a random 8-byte frame on a STATUS ID: 2^-16 (CRC) x 2^-2 (reserved bits) x
 * 4/16 (counter window of socketcan_motor.h, 3 values, + 1 for a pending resync) = 2^-20 =
 * 9.5e-7 per frame (7.2e-7 without a pending resync); derivation in docs/faults.md.
 *
 * Bus load at 1 kHz (worst-case bit stuffing, 8 data bytes: 135 bits with intermission):
 * per tick CMD_VOLTAGE + 2 STATUS = 405 bits, plus 2 HEALTH at 100 Hz = 27 bit/ms:
 * 432 kbit/s = 43.2 % of 1 Mbit/s (can_bus_load_1khz() computes it).
 */
#ifndef OMNI4_CAN_PROTO_H
#define OMNI4_CAN_PROTO_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define CAN_ID_CMD_VOLTAGE 0x010u
#define CAN_ID_CMD_CONTROL 0x011u
#define CAN_ID_STATUS(node) (0x020u + (unsigned)(node))
#define CAN_ID_HEALTH(node) (0x030u + (unsigned)(node))
#define CAN_NODES 2

/* Signal ranges are those of the signed raw fields: [-2^(n-1), 2^(n-1) - 1] LSB. */
#define CAN_VOLT_LSB 0.04f /* [V], 10 bit: -20.48 .. 20.44 */
#define CAN_VOLT_MAX 20.44f
#define CAN_CURR_LSB 0.02f /* [A], 10 bit: -10.24 .. 10.22 */
#define CAN_CURR_MAX 10.22f
#define CAN_SPEED_LSB 0.125f /* [rad/s], 11 bit: -128 .. 127.875 */
#define CAN_SPEED_MAX 127.875f

/* E2E data ID of a frame ID (enters the CRC, never sent). */
#define CAN_DATA_ID(id) (0x4F00u | ((unsigned)(id) & 0xFFu))
/* Counter window: a frame is accepted if its counter is 1 .. CAN_COUNTER_WINDOW ahead of the
 * last accepted one of its ID (up to CAN_COUNTER_WINDOW - 1 frames lost). */
#define CAN_COUNTER_WINDOW 3

enum can_control { CAN_CTL_ENABLE = 1, CAN_CTL_DISABLE = 2, CAN_CTL_CLEAR_FAULTS = 3 };

/* Driver-side fault bits (HEALTH.faults). */
#define CAN_DRV_OVERCURRENT 0x01u
#define CAN_DRV_OVERTEMP 0x02u
#define CAN_DRV_UNDERVOLTAGE 0x04u
#define CAN_DRV_HW 0x08u
/* No CMD_VOLTAGE for CAN_BOARD_CMD_TIMEOUT_US: the board disabled itself. */
#define CAN_DRV_CMD_TIMEOUT 0x10u

/* A driver board without a CMD_VOLTAGE for this long disables its bridges (its own watchdog,
 * behind the controller's). */
#define CAN_BOARD_CMD_TIMEOUT_US 50000

enum can_drv_state { CAN_STATE_DISABLED = 0, CAN_STATE_ENABLED = 1, CAN_STATE_FAULT = 2 };

/* A classic CAN frame, independent of any OS header. id holds the 11-bit or 29-bit identifier
 * and, as SocketCAN's can_id does, the frame-format flags below (same bit values). */
struct omni4_can_frame {
	uint32_t id;
	uint8_t dlc;
	uint8_t data[8];
};

#define OMNI4_CAN_EFF_FLAG 0x80000000u /* extended frame format (29-bit ID) */
#define OMNI4_CAN_RTR_FLAG 0x40000000u /* remote transmission request */
#define OMNI4_CAN_SFF_MASK 0x000007FFu /* standard frame ID bits */
#define OMNI4_CAN_EFF_MASK 0x1FFFFFFFu /* extended frame ID bits */

struct can_status {
	float current_a[2];   /* [A] channels 2n, 2n+1 */
	float speed_rad_s[2]; /* wheel speed after the gearbox [rad/s] */
};

struct can_health {
	uint8_t faults; /* CAN_DRV_* */
	float supply_v; /* [V] */
	int8_t temp_c;  /* [deg C] */
	uint8_t state;  /* enum can_drv_state */
};

/* CRC-16/CCITT-FALSE (check value 0x29B1 for "123456789"). */
uint16_t can_crc16(const uint8_t *p, size_t n);
/* The E2E CRC of a frame: data bytes 0-5, then the data ID of f->id. */
uint16_t can_frame_crc(const struct omni4_can_frame *f);

/* Encoders: -ERANGE for a value outside the signal's range or NaN; -EINVAL for a bad node. */
int can_encode_cmd_voltage(const float volts[4], bool enable, uint8_t counter,
                           struct omni4_can_frame *f);
int can_encode_control(enum can_control cmd, uint8_t counter, struct omni4_can_frame *f);
int can_encode_status(int node, const struct can_status *s, uint8_t counter,
                      struct omni4_can_frame *f);
int can_encode_health(int node, const struct can_health *h, uint8_t counter,
                      struct omni4_can_frame *f);

/* Decoders: -EINVAL wrong ID or DLC; -EBADMSG CRC mismatch or reserved bits set. *counter
 * gets the rolling counter. */
int can_decode_cmd_voltage(const struct omni4_can_frame *f, float volts[4], bool *enable,
                           uint8_t *counter);
int can_decode_control(const struct omni4_can_frame *f, enum can_control *cmd, uint8_t *counter);
int can_decode_status(const struct omni4_can_frame *f, int *node, struct can_status *s,
                      uint8_t *counter);
int can_decode_health(const struct omni4_can_frame *f, int *node, struct can_health *h,
                      uint8_t *counter);

/* Rolling counter check: 0 = the expected next value; -EALREADY = the same value again (stale
 * or replayed frame); otherwise the number of frames missed (1..14; 14 = one behind). */
int can_counter_gap(uint8_t prev, uint8_t now);

/* Worst-case bits on the wire of a classic base frame with n data bytes (stuffing, IFS). */
unsigned can_frame_bits_worst(unsigned n);
/* Fraction of a bitrate used by the protocol with the control loop at 1 kHz. */
double can_bus_load_1khz(double bitrate);

#endif /* OMNI4_CAN_PROTO_H */
