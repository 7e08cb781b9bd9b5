"""A throwaway Ray cluster for tests: ports picked free (not Ray's defaults), its processes found by
the temp dir their command lines name, and stopped by process id. ``ray stop`` is not used: it
stops every Ray process of the machine, other users' clusters too."""

from __future__ import annotations

import os
import signal
import socket
import time
from pathlib import Path


def free_ports(n: int) -> list[int]:
    """``n`` loopback ports free right now."""
    socks = [socket.socket() for _ in range(n)]
    try:
        for s in socks:
            s.bind(("127.0.0.1", 0))
        return [s.getsockname()[1] for s in socks]
    finally:
        for s in socks:
            s.close()


def node_ports(ports: list[int]) -> list[str]:
    """``ray start`` flags for the ports one node opens (six), so that two nodes on one machine, or
    a test's node and someone else's, do not collide."""
    names = ("node-manager", "object-manager", "dashboard-agent-listen", "dashboard-agent-grpc",
             "runtime-env-agent", "metrics-export")  # fmt: skip
    return [f"--{name}-port={port}" for name, port in zip(names, ports, strict=True)]


def cluster_pids(tag: str) -> list[int]:
    """Processes (other than this one) whose command line names ``tag`` (the cluster's temp dir)."""
    pids = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit() and int(d.name) != os.getpid():
            try:
                if tag in (d / "cmdline").read_bytes().decode(errors="replace"):
                    pids.append(int(d.name))
            except OSError:
                pass
    return pids


def stop_cluster(tag: str) -> None:
    """SIGTERM, then SIGKILL, the processes of the cluster whose temp dir is ``tag``."""
    for sig, wait in ((signal.SIGTERM, 10.0), (signal.SIGKILL, 5.0)):
        for pid in cluster_pids(tag):
            try:
                os.kill(pid, sig)
            except ProcessLookupError:
                pass
        deadline = time.monotonic() + wait
        while cluster_pids(tag) and time.monotonic() < deadline:
            time.sleep(0.2)
