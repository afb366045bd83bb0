"""Decodes the C encoder's sample frames (can_vectors) with cantools and drivers/can/omni4.dbc,
compares every signal with the value that went in, recomputes each E2E CRC-16 (with its data
ID) independently and checks that the reserved bits are 0.
usage: check_dbc.py DBC VECTORS_BINARY"""
import subprocess
import sys

import cantools


def crc16_ccitt_false(data):
    crc = 0xFFFF
    for b in data:
        crc ^= b << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
    return crc


def e2e_crc(frame_id, payload):
    """CRC over data bytes 0..5, then the data ID 0x4F00 | (ID & 0xFF), low byte first."""
    data_id = 0x4F00 | (frame_id & 0xFF)
    return crc16_ccitt_false(payload[:6] + bytes([data_id & 0xFF, data_id >> 8]))


def reserved_bits_clear(msg, payload):
    """Bits 0..43 that no signal covers must be 0."""
    word = int.from_bytes(payload, "little")
    used = 0
    for sig in msg.signals:
        used |= ((1 << sig.length) - 1) << sig.start
    return word & ((1 << 44) - 1) & ~used == 0


def main():
    db = cantools.database.load_file(sys.argv[1])
    lines = subprocess.run([sys.argv[2]], check=True, capture_output=True, text=True,
                           timeout=60).stdout  # a hang fails, naming the command
    assert crc16_ccitt_false(b"123456789") == 0x29B1  # the catalogue check value
    tol = {"voltage": 0.02, "current": 0.01, "speed": 0.0625, "supply": 0.005}
    passed = failed = 0
    for line in lines.splitlines():
        ident, data, *sigs = line.split()
        frame_id, payload = int(ident, 16), bytes.fromhex(data)
        decoded = db.decode_message(frame_id, payload, decode_choices=False)
        want_crc = e2e_crc(frame_id, payload)
        msg = db.get_message_by_frame_id(frame_id)
        ok = decoded["crc"] == want_crc and len(payload) == 8 and reserved_bits_clear(msg, payload)
        for s in sigs:
            name, value = s.split("=")
            t = next((v for k, v in tol.items() if name.startswith(k)), 1e-9)
            if abs(decoded[name] - float(value)) > t + 1e-9:
                print(f"FAIL {ident}: {name} C={value} DBC={decoded[name]}")
                ok = False
        if ok:
            passed += 1
            print(f"ok   {ident} {msg.name}: {decoded}")
        else:
            failed += 1
            print(f"FAIL {ident} {msg.name}: crc {decoded['crc']} want {want_crc}")
    print(f"{passed} passed, {failed} failed")
    sys.exit(1 if failed or not passed else 0)


if __name__ == "__main__":
    main()
