"""Cross-checks the VESC and ODrive codecs against drivers/can/vesc.dbc and odrive.dbc with
cantools: (1) frames written by hand from the vendors' documents decode to the documented values;
(2) every frame the C codecs encode (drive_vectors) decodes to the value that went in, with the ID
(command, controller / node, extended and RTR flags) and the length the DBC declares.
Both DBCs are written for controller / node 0: the ID's address part is taken off here.
usage: check_drive_dbc.py VESC_DBC ODRIVE_DBC VECTORS_BINARY"""
import struct
import subprocess
import sys

import cantools

EFF, RTR = 0x80000000, 0x40000000

# Hand-built from the documents: (protocol, frame ID with flags, data, node, {signal: value}).
HAND = [
    # comm_can.md's own example: SET_CURRENT (1) of 51 A to VESC ID 23: 51000 = 0x0000C738.
    ("vesc", EFF | 0x0117, "0000C738", 23, {"current": 51.0}),
    # SET_DUTY (0) to ID 4: -0.25 x 100000 = -25000 = 0xFFFF9E58.
    ("vesc", EFF | 0x0004, "FFFF9E58", 4, {"duty": -0.25}),
    # SET_RPM (3) to ID 9: 3000 = 0x00000BB8.
    ("vesc", EFF | 0x0309, "00000BB8", 9, {"erpm": 3000}),
    # STATUS (9) from ID 1: ERPM 1000 = 0x000003E8, 12.3 A x 10 = 123 = 0x007B,
    # duty 0.5 x 1000 = 500 = 0x01F4.
    ("vesc", EFF | 0x0901, "000003E8007B01F4", 1, {"erpm": 1000, "current": 12.3, "duty": 0.5}),
    # STATUS_4 (16 = 0x10) from ID 2: -5.5 degC -> -55 = 0xFFC9, 40.0 -> 400 = 0x0190,
    # -1.0 A -> -10 = 0xFFF6, 90 deg x 50 = 4500 = 0x1194.
    ("vesc", EFF | 0x1002, "FFC90190FFF61194", 2,
     {"temp_fet": -5.5, "temp_motor": 40.0, "current_in": -1.0, "pid_pos": 90.0}),
    # STATUS_5 (27 = 0x1B) from ID 3: tachometer -6 = 0xFFFFFFFA, 24.0 V x 10 = 240 = 0x00F0.
    ("vesc", EFF | 0x1B03, "FFFFFFFA00F00000", 3, {"tacho": -6, "input_voltage": 24.0}),
    # PROCESS_SHORT_BUFFER (8) to host id 254 from VESC 1, a reply (mode 1) to
    # COMM_GET_VALUES_SELECTIVE (50 = 0x32) with mask bit 15 (0x00008000): fault code 5.
    ("vesc", EFF | 0x08FE, "0101320000800005", 254,
     {"sender": 1, "mode": 1, "packet_id": 50, "values_mask": 0x8000, "fault_code": 5}),
    # Set_Input_Vel (0x0D) to node 1: ID 1 << 5 | 0x0D = 0x2D; 1.0f = 0x3F800000 little-endian,
    # torque feed-forward 0.0f.
    ("odrive", 0x02D, "0000803F00000000", 1, {"input_vel": 1.0, "input_torque_ff": 0.0}),
    # Heartbeat (0x01) from node 2: ID 0x41; no error, state 8 (closed loop), procedure result 0,
    # trajectory done 1 (byte 6).
    ("odrive", 0x041, "0000000008000100", 2,
     {"axis_error": 0, "axis_state": 8, "procedure_result": 0, "trajectory_done": 1}),
    # Get_Encoder_Estimates (0x09) from node 0: -2.0f = 0xC0000000, 0.5f = 0x3F000000.
    ("odrive", 0x009, "000000C00000003F", 0, {"pos_estimate": -2.0, "vel_estimate": 0.5}),
    # Get_Bus_Voltage_Current (0x17) from node 3: ID 0x77; 24.0f = 0x41C00000, -0.5f = 0xBF000000.
    ("odrive", 0x077, "0000C041000000BF", 3, {"bus_voltage": 24.0, "bus_current": -0.5}),
    # Set_Controller_Mode (0x0B) to node 1: ID 0x2B; torque control 1, passthrough 1.
    ("odrive", 0x02B, "0100000001000000", 1, {"control_mode": 1, "input_mode": 1}),
]


def split(proto, frame_id):
    """(DBC key, node) of a frame ID; raises on a flag or address the protocol forbids."""
    if proto == "vesc":
        assert frame_id & EFF and not frame_id & RTR, "VESC frames are extended data frames"
        assert frame_id & 0x1FFF0000 == 0, "bits 28-16 unused"
        return frame_id & ~0xFF & ~RTR, frame_id & 0xFF
    assert not frame_id & EFF and frame_id & ~RTR <= 0x7FF, "ODrive frames are standard"
    return frame_id & 0x1F, (frame_id & 0x7FF) >> 5


def close(sig, got, want):
    if sig.is_float:  # the C side sends binary32: compare with the value rounded to it
        return got == struct.unpack("<f", struct.pack("<f", want))[0]
    return abs(got - want) <= sig.scale / 2 + 1e-9


def check(dbs, proto, frame_id, dlc, data, node, want):
    """Empty list if the frame is the message with those values, else what differs."""
    key, got_node = split(proto, frame_id)
    msg = dbs[proto].get_message_by_frame_id(key)
    errs = [] if got_node == node else [f"node {got_node} want {node}"]
    if dlc != msg.length:
        errs.append(f"DLC {dlc} want {msg.length}")
    if frame_id & RTR:
        return errs + ([] if msg.senders == ["ODRIVE"] and not want else ["RTR of a command"])
    decoded = msg.decode(data, decode_choices=False) if msg.length else {}
    for name, value in want.items():
        sig = msg.get_signal_by_name(name)
        if not close(sig, decoded[name], value):
            errs.append(f"{name}: DBC {decoded[name]} want {value}")
    return errs


def vectors(binary):
    out = subprocess.run([binary], check=True, capture_output=True, text=True,
                         timeout=60).stdout  # a hang fails, naming the command
    for line in out.splitlines():
        proto, ident, dlc, data, node, *sigs = line.split()
        want = {k: float(v) for k, v in (s.split("=") for s in sigs)}
        payload = b"" if data == "-" else bytes.fromhex(data)
        yield proto, int(ident, 16), int(dlc), payload, int(node.split("=")[1]), want


def main():
    dbs = {"vesc": cantools.database.load_file(sys.argv[1]),
           "odrive": cantools.database.load_file(sys.argv[2])}
    cases = [("hand", p, i, len(bytes.fromhex(d)), bytes.fromhex(d), n, w)
             for p, i, d, n, w in HAND]
    cases += [("C", *v) for v in vectors(sys.argv[3])]
    passed = failed = 0
    for origin, proto, ident, dlc, data, node, want in cases:
        try:
            errs = check(dbs, proto, ident, dlc, data, node, want)
        except (AssertionError, KeyError) as e:
            errs = [f"{type(e).__name__} {e}"]
        status = "FAIL" if errs else "ok  "
        print(f"{status} {origin:4} {proto:6} {ident:08X} {data.hex()} {want} {'; '.join(errs)}")
        passed, failed = passed + (not errs), failed + bool(errs)
    print(f"{passed} passed, {failed} failed")
    sys.exit(1 if failed or not passed else 0)


if __name__ == "__main__":
    main()
