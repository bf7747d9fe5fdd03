"""How much memory this process may still take: the machine's physical memory, or less under
an address-space limit (``ulimit -v``, HPC schedulers) or a cgroup memory limit (containers),
so that an oversize request is a MemoryError before a kernel allocates, never an abort."""

from __future__ import annotations

import os
from pathlib import Path

try:  # POSIX
    import resource
except ImportError:  # pragma: no cover - Windows
    resource = None  # type: ignore[assignment]


def physical_memory() -> int | None:
    """Bytes of physical memory, None where unknown."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):  # pragma: no cover - non-POSIX
        return None


def address_space_headroom() -> int | None:
    """Bytes of address space left under RLIMIT_AS (its soft limit minus the address space in
    use), None when no limit is set or it cannot be read."""
    if resource is None:  # pragma: no cover
        return None
    limit, _ = resource.getrlimit(resource.RLIMIT_AS)
    if limit == resource.RLIM_INFINITY:
        return None
    try:
        pages = int(Path("/proc/self/statm").read_text().split()[0])
    except (OSError, ValueError, IndexError):  # pragma: no cover - no /proc
        return limit
    return max(limit - pages * resource.getpagesize(), 0)


def cgroup_headroom() -> int | None:
    """Bytes left under a cgroup v2 (memory.max − memory.current) or v1 memory limit, None
    when there is none."""
    for limit_file, usage_file in [
        ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),
        (
            "/sys/fs/cgroup/memory/memory.limit_in_bytes",
            "/sys/fs/cgroup/memory/memory.usage_in_bytes",
        ),
    ]:
        try:
            limit_text = Path(limit_file).read_text().strip()
            usage = int(Path(usage_file).read_text().strip())
        except (OSError, ValueError):
            continue
        if limit_text == "max" or not limit_text.isdigit():
            return None
        limit = int(limit_text)
        if limit >= 1 << 60:  # v1's "no limit" is a huge number
            return None
        return max(limit - usage, 0)
    return None


def memory_budget() -> tuple[int, str] | None:
    """(bytes, what bounds them): the least of the physical memory and the headrooms under
    an address-space or cgroup limit; None when none is known."""
    bounds = [
        (physical_memory(), "of memory of this machine"),
        (address_space_headroom(), "of address space left under this process's limit"),
        (cgroup_headroom(), "left under this process's memory limit (cgroup)"),
    ]
    known = [(b, what) for b, what in bounds if b is not None]
    return min(known) if known else None
