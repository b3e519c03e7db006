#!/usr/bin/python3
"""Checks that every tracked C++ file follows .clang-format; one JUnit test case per package.

Usage: check_format.py OUTPUT.xml REPO_ROOT
"""
import pathlib
import subprocess
import sys
import xml.etree.ElementTree as ET

CPP_SUFFIXES = {".cpp", ".h", ".hpp", ".inc"}


def main():
    output, root = sys.argv[1], pathlib.Path(sys.argv[2])
    tracked = subprocess.run(["git", "-C", str(root), "ls-files"], capture_output=True, text=True,
                             check=False).stdout.split()
    if not tracked:  # not a git checkout (an exported tree): every file below the packages
        tracked = [str(p.relative_to(root)) for p in root.rglob("*") if "build" not in p.parts]
    by_package = {}
    for name in tracked:
        if pathlib.Path(name).suffix in CPP_SUFFIXES:
            by_package.setdefault(name.split("/")[0], []).append(name)
    suite = ET.Element("testsuite", name="clang_format", tests=str(len(by_package)))
    failures = 0
    for package, files in sorted(by_package.items()):
        run = subprocess.run(["clang-format", "--dry-run", "-Werror", *files], cwd=root,
                             capture_output=True, text=True, check=False)
        bad = sorted({line.split(":")[0] for line in run.stderr.splitlines() if ": error:" in line})
        case = ET.SubElement(suite, "testcase", classname="clang_format", name=package)
        print(f"clang-format {package}: {'ok' if run.returncode == 0 else 'differs: ' + ' '.join(bad)}")
        if run.returncode != 0:
            failures += 1
            ET.SubElement(case, "failure",
                          message="not formatted (run clang-format -i): " + " ".join(bad or [run.stderr[:300]]))
    suite.set("failures", str(failures))
    ET.ElementTree(suite).write(output, encoding="unicode")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
