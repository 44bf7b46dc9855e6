"""Merge the stations' studies argv[2:] into the central study argv[1], in lockstep with the test that
started it: after each frame batch it copies it prints ``copied <n>`` (n batches so far) and waits
for a line on its standard input. The test kills this process with SIGKILL while it waits, inside
the merge's transaction, however busy the machine is."""

from __future__ import annotations

import sys

from microg.study import framelog, stations
from microg.study.store import open_study


def main(central: str, *folders: str) -> None:
    copy = framelog.copy
    copied = 0

    def reporting(*args) -> None:
        nonlocal copied
        copy(*args)
        copied += 1
        print(f"copied {copied}", flush=True)
        sys.stdin.readline()

    framelog.copy = reporting
    with open_study(central) as store:
        stations.merge_stations(store, folders)
    print("done", flush=True)


if __name__ == "__main__":
    main(*sys.argv[1:])
