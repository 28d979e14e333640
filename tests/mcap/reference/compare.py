#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Compares what read.mjs decoded from a file with what its writer says it wrote.

usage: compare.py EXPECTED.json ACTUAL.json [--first N]
  --first N   only the first N expected messages are in the file (a recovered one)
Prints each difference (at most 20) and exits 1 if there is any.
"""
import json
import sys


def differences(want, got, where):
    if isinstance(want, dict):
        if not isinstance(got, dict):
            yield f"{where}: expected an object, got {got!r}"
            return
        for key in sorted(set(want) | set(got)):
            if key not in got:
                yield f"{where}.{key}: missing"
            elif key not in want:
                yield f"{where}.{key}: not expected ({got[key]!r})"
            else:
                yield from differences(want[key], got[key], f"{where}.{key}")
    elif isinstance(want, list):
        if not isinstance(got, list) or len(got) != len(want):
            yield f"{where}: expected {len(want)} items, got {got!r}"
            return
        for i, (w, g) in enumerate(zip(want, got)):
            yield from differences(w, g, f"{where}[{i}]")
    elif isinstance(want, bool) or isinstance(got, bool):
        if want is not got:
            yield f"{where}: expected {want!r}, got {got!r}"
    elif want != got:
        yield f"{where}: expected {want!r}, got {got!r}"


def main():
    args = sys.argv[1:]
    first = None
    if "--first" in args:
        i = args.index("--first")
        first = int(args[i + 1])
        del args[i:i + 2]
    if len(args) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    with open(args[0]) as f:
        want = json.load(f)
    with open(args[1]) as f:
        got = json.load(f)
    found = []
    if got["header"]["library"] != want["library"]:
        found.append(f"header.library: expected {want['library']!r}, got {got['header']['library']!r}")
    messages = want["messages"] if first is None else want["messages"][:first]
    found += list(differences(messages, got["messages"], "messages"))
    for line in found[:20]:
        print(line)
    if found:
        print(f"{len(found)} difference(s) between {args[0]} and {args[1]}")
        return 1
    print(f"{len(messages)} messages decoded as written")
    return 0


if __name__ == "__main__":
    sys.exit(main())
