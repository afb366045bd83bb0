"""The self-test's record of checks (test_plant.py and test_plant_sensors.py share it)."""

RESULTS = []


def check(name, ok, figure):
    """Record and print one check: name, pass/fail, the figure it rests on."""
    RESULTS.append(bool(ok))
    print(f"{'ok  ' if ok else 'FAIL'} {name}: {figure}")
