#!/usr/bin/python3
"""Sums every JUnit XML file under a folder and prints "N passed, N failed".

catkin's run_tests, rostest, gtest and pytest all leave JUnit XML; their exit codes
cannot be trusted alone (catkin_make run_tests exits 0 on failure), so the
verdict of scripts/test is computed here. A skipped test counts as failed: the
project has no test that may be skipped to get green.
"""
import pathlib
import sys
import xml.etree.ElementTree as ET


def count_cases(path):
    """Returns (passed, failed_names) for one JUnit file."""
    passed, failed = 0, []
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as error:
        return 0, [f"{path}: unreadable result file ({error})"]
    cases = list(root.iter("testcase"))
    if not cases:
        # A rostest whose test node never ran leaves a suite with errors but no case.
        suites = [root] if root.tag == "testsuite" else list(root.iter("testsuite"))
        broken = sum(int(s.get("errors", 0)) + int(s.get("failures", 0)) for s in suites)
        if broken:
            failed.append(f"{path}: {broken} error(s) before any test case ran")
        return 0, failed
    for case in cases:
        name = f"{case.get('classname', '')}.{case.get('name', '')}"
        bad = [c for c in case if c.tag in ("failure", "error", "skipped")]
        if bad:
            message = " | ".join((bad[0].get("message") or "").split("\n"))
            failed.append(f"{name}: {bad[0].tag}: {message[:300]}")
        else:
            passed += 1
    return passed, failed


def main():
    results = pathlib.Path(sys.argv[1])
    total_passed, all_failed = 0, []
    files = sorted(results.rglob("*.xml"))
    for path in files:
        passed, failed = count_cases(path)
        total_passed += passed
        all_failed.extend(failed)
    for line in all_failed:
        print("FAILED", line)
    if not files:
        all_failed.append("no result files")
        print(f"FAILED: no JUnit result files under {results}")
    print(f"{total_passed} passed, {len(all_failed)} failed")
    return 1 if all_failed or total_passed == 0 else 0


if __name__ == "__main__":
    sys.exit(main())
