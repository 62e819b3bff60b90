"""What a run's processes use: CPU seconds and memory of a process and its descendants (psutil)."""

import contextlib

import psutil

__all__ = ["process_tree_cpu_s", "process_tree_rss_mb"]


def process_tree_rss_mb(process: psutil.Process) -> float:
    """Memory (MiB) of ``process`` (RSS) and its descendants (USS: shared pages left out, so a lower bound)."""
    total = process.memory_info().rss
    for child in process.children(recursive=True):
        with contextlib.suppress(psutil.NoSuchProcess, psutil.AccessDenied):
            total += child.memory_full_info().uss
    return total / 2**20


def process_tree_cpu_s(process: psutil.Process | None = None) -> float:
    """CPU seconds (user + system) of ``process`` (default: this one) and its descendants, ended ones once waited for."""
    process = process or psutil.Process()
    total = 0.0
    for member in [process, *process.children(recursive=True)]:
        with contextlib.suppress(psutil.NoSuchProcess):
            times = member.cpu_times()
            total += times.user + times.system + times.children_user + times.children_system
    return total
