"""A ROS domain of its own for each cell of a campaign on a host (ROS-free).

Two cells in one domain would hear each other's topics. :func:`lease_domain` takes a
domain id nobody else on this host holds: an exclusive ``flock`` on
``<lock dir>/domain_<id>.lock`` (released by the kernel when the holder exits, however it
exits, so a crashed cell never strands a domain), skipping ids whose DDS ports something
on the host has already bound (a ``hexctl demo`` or a test run beside the campaign, which
take no lock). It sets ``ROS_DOMAIN_ID`` in the environment given, and keeps discovery on
the host (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``, no ``ROS_STATIC_PEERS``): cells of
one campaign on different hosts of a Ray cluster may then share an id without meeting.

Ids 1..101: the DDS ports of these (7400 + 250 * id + 0..249, the RTPS mapping that Fast
DDS and Cyclone DDS use) lie below the ephemeral port range, as ``hexctl demo`` chooses.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
from pathlib import Path

#: the ids a cell may take (ports below Linux's ephemeral range, 32768)
DOMAINS = range(1, 102)
#: where the locks live (one directory per host: the locks are the host's)
LOCK_DIR = Path(os.environ.get("HEX_CAMPAIGN_LOCK_DIR", "/tmp/hex_control_domains"))
#: RTPS port mapping: PB + DG * domain, a domain's ports within [base, base + DG)
PORT_BASE, DOMAIN_GAIN = 7400, 250


def bound_udp_ports(tables=("/proc/net/udp", "/proc/net/udp6")) -> set[int]:
    """The local UDP ports bound on this host (Linux' /proc tables; empty elsewhere)."""
    ports = set()
    for table in tables:
        try:
            lines = Path(table).read_text().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            fields = line.split()
            if len(fields) > 1 and ":" in fields[1]:
                ports.add(int(fields[1].rsplit(":", 1)[1], 16))
    return ports


def domains_in_use(ports: set[int]) -> set[int]:
    """Domain ids with a DDS port among ``ports``."""
    return {(port - PORT_BASE) // DOMAIN_GAIN for port in ports if port >= PORT_BASE}


@contextlib.contextmanager
def lease_domain(environment=None, lock_dir: Path | None = None, domains=DOMAINS, start: int | None = None):
    """Hold a domain id of this host for the ``with`` block; yields it, with
    ``environment`` (default ``os.environ``) set to it (and restored after). Tries the
    ids from ``start`` (default: from the process id, so that cells starting together
    do not all race for the first) round ``domains``. RuntimeError if every id is held."""
    environment = os.environ if environment is None else environment
    directory = Path(lock_dir or LOCK_DIR)
    directory.mkdir(parents=True, exist_ok=True)
    with contextlib.suppress(OSError):  # any user's cells share the host's ids
        directory.chmod(0o1777)
    ids = list(domains)
    first = (os.getpid() if start is None else start) % len(ids)
    busy = domains_in_use(bound_udp_ports())
    for domain in ids[first:] + ids[:first]:
        if domain in busy:
            continue
        descriptor = _lock(directory / f"domain_{domain}.lock")
        if descriptor is None:
            continue
        saved = {name: environment.get(name) for name in
                 ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_STATIC_PEERS")}
        try:
            environment["ROS_DOMAIN_ID"] = str(domain)
            environment["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
            environment.pop("ROS_STATIC_PEERS", None)
            yield domain
        finally:
            for name, value in saved.items():
                if value is None:
                    environment.pop(name, None)
                else:
                    environment[name] = value
            os.close(descriptor)
        return
    raise RuntimeError(f"every ROS domain {ids[0]}..{ids[-1]} of this host is held or in use "
                       f"(locks in {directory})")


def _lock(path: Path) -> int | None:
    """An open descriptor holding an exclusive lock on ``path``, or None if another holds it."""
    try:
        descriptor = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    except PermissionError:  # another user's file: a lock needs only a descriptor
        descriptor = os.open(path, os.O_RDONLY)
    try:
        fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(descriptor)
        return None
    return descriptor
