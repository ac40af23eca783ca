"""How much memory a new allocation may take, and refusing one that would not fit.

The budget is the least of what the system has available (``MemAvailable``), what the
process's control group allows (cgroup v2 ``memory.max`` less ``memory.current``) and what
its address-space limit leaves (``RLIMIT_AS``, ``ulimit -v``, less the current size): a
budget from ``MemAvailable`` alone ignored ``ulimit -v`` and ended in ``std::bad_alloc``.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["available_memory", "check_allocation"]


def _meminfo() -> int | None:
    try:
        with open("/proc/meminfo", encoding="ascii") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, OSError, ValueError):
        return None


def _cgroup(root: Path = Path("/sys/fs/cgroup")) -> int | None:
    """Bytes the process's cgroup (v2) still allows, or None without a limit."""
    try:
        relative = Path("/proc/self/cgroup").read_text(encoding="ascii").strip()
        group = root / relative.split("::", 1)[1].lstrip("/") if "::" in relative else root
        limit = (group / "memory.max").read_text(encoding="ascii").strip()
        if limit == "max":
            return None
        used = int((group / "memory.current").read_text(encoding="ascii").strip())
        return max(int(limit) - used, 0)
    except (OSError, ValueError, IndexError):
        return None


def _rlimit() -> int | None:
    """Bytes of address space ``RLIMIT_AS`` still leaves the process, or None without one."""
    try:
        import resource

        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
        if soft == resource.RLIM_INFINITY:
            return None
        with open("/proc/self/statm", encoding="ascii") as handle:
            size = int(handle.read().split()[0]) * int(os.sysconf("SC_PAGE_SIZE"))
        return max(int(soft) - size, 0)
    except (ImportError, OSError, ValueError, IndexError, AttributeError):
        return None


def available_memory() -> int | None:
    """Bytes a new allocation may take: the least of the system, cgroup and rlimit budgets.

    None when none of them can be read (not Linux, no ``/proc``).
    """
    known = [b for b in (_meminfo(), _cgroup(), _rlimit()) if b is not None]
    return min(known) if known else None


def check_allocation(nbytes: float, what: str, fix: str) -> None:
    """Raise a ValueError naming ``what``, its size, the budget and ``fix`` if it cannot fit."""
    free = available_memory()
    if free is None or nbytes <= free:
        return
    raise ValueError(
        f"{what} needs about {nbytes / 2**30:.3g} GiB of memory, more than the "
        f"{free / 2**30:.3g} GiB available (system, cgroup and ulimit -v); {fix}"
    )
