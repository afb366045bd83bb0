/* Prints sample frames encoded by the C protocol code with the values that went in, one per
 * line: "ID DATA(hex) signal=value ...", for the DBC cross-check (check_dbc.py). */
#include <stdio.h>

#include "omni4/drivers/can_proto.h"

static void print(const struct omni4_can_frame *f, const char *signals)
{
	printf("%03X ", (unsigned)f->id);
	for (int i = 0; i < f->dlc; i++)
		printf("%02X", f->data[i]);
	printf(" %s\n", signals);
}

int main(void)
{
	struct omni4_can_frame f;
	char sig[256];
	const float v[][4] = {{12, -12, 0.52f, -0.04f}, {20.44f, -20.48f, 3.32f, 0}};

	for (int k = 0; k < 2; k++) {
		can_encode_cmd_voltage(v[k], k == 0, (uint8_t)(k + 5), &f);
		snprintf(sig, sizeof(sig),
		         "voltage_0=%g voltage_1=%g voltage_2=%g voltage_3=%g enable=%d counter=%d "
		         "crc=%d",
		         v[k][0], v[k][1], v[k][2], v[k][3], k == 0, k + 5,
		         f.data[6] | f.data[7] << 8);
		print(&f, sig);
	}
	can_encode_control(CAN_CTL_CLEAR_FAULTS, 11, &f);
	snprintf(sig, sizeof(sig), "command=3 counter=11 crc=%d", f.data[6] | f.data[7] << 8);
	print(&f, sig);
	const struct can_status s[2] = {{{1.5f, -2.24f}, {100.125f, -36.5f}},
	                                {{0.02f, -10.24f}, {127.875f, -0.125f}}};

	for (int n = 0; n < 2; n++) {
		can_encode_status(n, &s[n], (uint8_t)(14 + n), &f);
		snprintf(sig, sizeof(sig),
		         "current_%d=%g current_%d=%g speed_%d=%g speed_%d=%g counter=%d crc=%d",
		         2 * n, s[n].current_a[0], 2 * n + 1, s[n].current_a[1], 2 * n,
		         s[n].speed_rad_s[0], 2 * n + 1, s[n].speed_rad_s[1], (14 + n) & 15,
		         f.data[6] | f.data[7] << 8);
		print(&f, sig);
	}
	const struct can_health h = {CAN_DRV_UNDERVOLTAGE | CAN_DRV_HW, 11.87f, -12,
	                             CAN_STATE_ENABLED};

	for (int n = 0; n < 2; n++) {
		can_encode_health(n, &h, 7, &f);
		snprintf(sig, sizeof(sig),
		         "faults=12 supply=11.87 temperature=-12 state=1 counter=7 crc=%d",
		         f.data[6] | f.data[7] << 8);
		print(&f, sig);
	}
	return 0;
}
