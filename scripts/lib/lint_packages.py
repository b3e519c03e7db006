#!/usr/bin/python3
"""Runs catkin_lint on each package and writes one JUnit test case per package.

A package passes when catkin_lint reports no error (warnings are printed).
Usage: lint_packages.py OUTPUT.xml PACKAGE_DIR...
"""
import subprocess
import sys
import xml.etree.ElementTree as ET


def main():
    output, packages = sys.argv[1], sys.argv[2:]
    suite = ET.Element("testsuite", name="catkin_lint", tests=str(len(packages)))
    failures = 0
    for package in packages:
        run = subprocess.run(["catkin_lint", "-W2", "--color", "never", "--offline", package],
                             capture_output=True, text=True, check=False)
        report = (run.stdout + run.stderr).strip()
        print(f"catkin_lint {package}: {'ok' if run.returncode == 0 else 'ERRORS'}")
        if report:
            print(report)
        case = ET.SubElement(suite, "testcase", classname="catkin_lint", name=package)
        if run.returncode != 0:
            failures += 1
            ET.SubElement(case, "failure", message=report)
    suite.set("failures", str(failures))
    ET.ElementTree(suite).write(output, encoding="unicode")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
