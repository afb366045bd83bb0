/* Prints sample frames encoded by the VESC and ODrive codecs with the values that went in, one per
 * line: "PROTOCOL ID(hex, with the EFF/RTR flag bits) DLC DATA(hex or -) node=N signal=value ...",
 * for the DBC cross-check (check_drive_dbc.py). A saturated input is printed as the value the
 * document's range makes of it. */
#include <stdio.h>

#include "omni4/drivers/odrive_proto.h"
#include "omni4/drivers/vesc_proto.h"

static void print(const char *proto, const struct omni4_can_frame *f, unsigned node,
                  const char *signals)
{
	printf("%s %08X %u ", proto, (unsigned)f->id, f->dlc);
	for (int i = 0; i < f->dlc; i++)
		printf("%02X", f->data[i]);
	printf("%s node=%u %s\n", f->dlc ? "" : "-", node, signals);
}

static void vesc(void)
{
	struct omni4_can_frame f;
	char sig[200];

	vesc_encode_set_duty(7, 0.5f, &f);
	print("vesc", &f, 7, "duty=0.5");
	vesc_encode_set_duty(VESC_ID_BROADCAST, -1.3f, &f);
	print("vesc", &f, 255, "duty=-1");
	vesc_encode_set_current(23, 51.0f, &f);
	print("vesc", &f, 23, "current=51");
	vesc_encode_set_current(1, -12.345f, &f);
	print("vesc", &f, 1, "current=-12.345");
	vesc_encode_set_current_brake(2, 20.5f, &f);
	print("vesc", &f, 2, "current_brake=20.5");
	vesc_encode_set_rpm(3, -15000.0f, &f);
	print("vesc", &f, 3, "erpm=-15000");
	const struct vesc_status1 s1 = {-123456, 12.3f, -0.456f};
	const struct vesc_status4 s4 = {25.3f, 60.1f, -3.2f, 180.02f};
	const struct vesc_status5 s5 = {-987654, 24.1f};

	vesc_encode_status1(5, &s1, &f);
	snprintf(sig, sizeof(sig), "erpm=%d current=%g duty=%g", (int)s1.erpm, s1.current_a,
	         s1.duty);
	print("vesc", &f, 5, sig);
	vesc_encode_status4(6, &s4, &f);
	snprintf(sig, sizeof(sig), "temp_fet=%g temp_motor=%g current_in=%g pid_pos=%g",
	         s4.temp_fet_c, s4.temp_motor_c, s4.current_in_a, s4.pid_pos_deg);
	print("vesc", &f, 6, sig);
	vesc_encode_status5(77, &s5, &f);
	snprintf(sig, sizeof(sig), "tacho=%d input_voltage=%g reserved=0", (int)s5.tacho_steps,
	         s5.input_v);
	print("vesc", &f, 77, sig);
}

static void odrive_commands(void)
{
	struct omni4_can_frame f;

	odrive_encode_set_axis_state(3, ODRIVE_AXIS_STATE_CLOSED_LOOP, &f);
	print("odrive", &f, 3, "requested_state=8");
	odrive_encode_set_controller_mode(3, ODRIVE_CONTROL_VELOCITY, ODRIVE_INPUT_VEL_RAMP, &f);
	print("odrive", &f, 3, "control_mode=2 input_mode=2");
	odrive_encode_set_input_vel(63, 2.5f, -0.125f, &f);
	print("odrive", &f, 63, "input_vel=2.5 input_torque_ff=-0.125");
	odrive_encode_set_input_torque(5, -0.7f, &f);
	print("odrive", &f, 5, "input_torque=-0.699999988");
	odrive_encode_clear_errors(5, &f);
	print("odrive", &f, 5, "identify=0");
	odrive_encode_estop(5, &f);
	print("odrive", &f, 5, "");
	odrive_encode_request(2, ODRIVE_CMD_GET_ENCODER_ESTIMATES, &f);
	print("odrive", &f, 2, "");
}

static void odrive_status(void)
{
	struct omni4_can_frame f;
	char sig[200];
	const struct odrive_heartbeat h = {0x02000200u, 8, 1, true};
	const struct odrive_encoder_estimates e = {12.5f, -3.1f};
	const struct odrive_iq q = {4.0f, 3.9f};
	const struct odrive_bus b = {24.2f, -1.5f};

	odrive_encode_heartbeat(1, &h, &f);
	print("odrive", &f, 1,
	      "axis_error=33554944 axis_state=8 procedure_result=1 trajectory_done=1");
	odrive_encode_encoder_estimates(1, &e, &f);
	snprintf(sig, sizeof(sig), "pos_estimate=%.9g vel_estimate=%.9g", e.pos_turn, e.vel_turn_s);
	print("odrive", &f, 1, sig);
	odrive_encode_iq(4, &q, &f);
	snprintf(sig, sizeof(sig), "iq_setpoint=%.9g iq_measured=%.9g", q.setpoint_a, q.measured_a);
	print("odrive", &f, 4, sig);
	odrive_encode_bus(62, &b, &f);
	snprintf(sig, sizeof(sig), "bus_voltage=%.9g bus_current=%.9g", b.voltage_v, b.current_a);
	print("odrive", &f, 62, sig);
}

int main(void)
{
	vesc();
	odrive_commands();
	odrive_status();
	return 0;
}
