"""Decodes the C encoder's sample frames (can_vectors) with cantools and drivers/can/omni4.dbc,
compares every signal with the value that went in, and recomputes each CRC independently.
usage: check_dbc.py DBC VECTORS_BINARY"""
import subprocess
import sys

import cantools


def crc8_sae_j1850(data):
    crc = 0xFF
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1D) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc ^ 0xFF


def main():
    db = cantools.database.load_file(sys.argv[1])
    lines = subprocess.run([sys.argv[2]], check=True, capture_output=True, text=True).stdout
    tol = {"voltage": 0.005, "current": 0.0025, "speed": 0.025, "supply": 0.005}
    passed = failed = 0
    for line in lines.splitlines():
        ident, data, *sigs = line.split()
        frame_id, payload = int(ident, 16), bytes.fromhex(data)
        decoded = db.decode_message(frame_id, payload, decode_choices=False)
        want_crc = crc8_sae_j1850(bytes([frame_id & 0xFF, frame_id >> 8]) + payload[:7])
        ok = decoded["crc"] == want_crc
        for s in sigs:
            name, value = s.split("=")
            t = next((v for k, v in tol.items() if name.startswith(k)), 1e-9)
            if abs(decoded[name] - float(value)) > t + 1e-9:
                print(f"FAIL {ident}: {name} C={value} DBC={decoded[name]}")
                ok = False
        msg = db.get_message_by_frame_id(frame_id).name
        if ok:
            passed += 1
            print(f"ok   {ident} {msg}: {decoded}")
        else:
            failed += 1
            print(f"FAIL {ident} {msg}: crc {decoded['crc']} want {want_crc}")
    print(f"{passed} passed, {failed} failed")
    sys.exit(1 if failed or not passed else 0)


if __name__ == "__main__":
    main()
