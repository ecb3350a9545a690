"""What every benchmark shares: clean measurements in child processes, the machine's
description, number formats, and writing a generated section into a document.

Peak memory is the peak resident set size of the process during the measured call minus
its resident size just before it (Linux: the high-water mark is reset through
/proc/self/clear_refs, then read as VmHWM; `resource.getrusage` where that is not
possible). It includes everything the call kept alive at its worst moment (the tool path,
the output, the emitter's own structures) and costs nothing while timing, unlike
tracemalloc. One child process per case keeps one case's garbage out of the next one's
figure. Below a few MB the figure is at the allocator's granularity (1 MiB arenas).
"""

from __future__ import annotations

import json
import os
import platform
import resource
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from playwright.sync_api import FloatRect, Page

ROOT = Path(__file__).resolve().parents[1]
VENV_BIN = Path(sys.executable).parent
Result = dict[str, Any]


# -- measuring ------------------------------------------------------------------------------


def rss_now() -> int:
    """This process's resident set size now, in bytes (Linux /proc)."""
    pages = int(Path("/proc/self/statm").read_text().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE")


def reset_peak() -> bool:
    """Reset this process's resident high-water mark (Linux); False where it cannot."""
    try:
        Path("/proc/self/clear_refs").write_text("5")
    except OSError:
        return False
    return True


def rss_peak() -> int:
    """This process's peak resident set size since the last reset, in bytes."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) * 1024
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # KiB on Linux


def measure(call: Callable[[], Any]) -> tuple[Any, float, int]:
    """(result, seconds, peak bytes above the resident size before) of one call.

    Without a resettable high-water mark the peak is only meaningful in a process that
    has not been bigger before, so the benchmarks measure once per child (`run_child`).
    """
    reset_peak()
    before = rss_now()
    start = time.perf_counter()
    result = call()
    seconds = time.perf_counter() - start
    return result, seconds, max(0, rss_peak() - before)


def best_time(call: Callable[[], Any], budget: float = 2.0, most: int = 5) -> float:
    """The shortest of up to `most` runs of `call`, stopping once `budget` seconds are used."""
    times: list[float] = []
    started = time.perf_counter()
    while len(times) < most and (not times or time.perf_counter() - started < budget):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return min(times)


def drag(page: Page, box: FloatRect | None, seconds: float, reach: float) -> tuple[float, int]:
    """Drag with the mouse across the middle of `box` (a Playwright bounding box) for about
    `seconds`, back and forth over `reach` px; (seconds it took, mouse moves sent). The
    frames shown meanwhile are the page's own count, read by the caller."""
    assert box is not None
    cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.mouse.move(cx, cy)
    page.mouse.down()
    began = time.perf_counter()
    step = 0
    while time.perf_counter() - began < seconds:
        step += 1
        page.mouse.move(cx + reach * ((step % 40) / 40 - 0.5), cy + reach / 10 * (step % 7))
    page.mouse.up()
    return time.perf_counter() - began, step


def percentile(values: Sequence[float], p: float) -> float:
    """The p-th percentile (0-100) by linear interpolation; NaN for no values."""
    if not values:
        return float("nan")
    ordered = sorted(values)
    rank = (len(ordered) - 1) * p / 100
    low = int(rank)
    high = min(low + 1, len(ordered) - 1)
    return ordered[low] + (ordered[high] - ordered[low]) * (rank - low)


@dataclass
class Budget:
    """When the whole run must be over: `run_child` never lets a child outlive it by more
    than `grace` seconds, and starts none after it."""

    deadline: float = float("inf")
    grace: float = 60.0

    def start(self, seconds: float) -> None:
        self.deadline = time.monotonic() + seconds

    def limit(self, timeout: float) -> float:
        """The time a child started now may take: `timeout`, within the budget."""
        return min(timeout, self.deadline + self.grace - time.monotonic())


BUDGET = Budget()


@dataclass(frozen=True)
class InstalledWheel:
    """The wheel a shop installs, with the G-code importer compiled (`make wheel-native`),
    in a fresh virtual environment; `shim` is a directory holding only a link to bench/, so
    a child run there imports `bench` from the checkout and `app` from site-packages."""

    bin: Path
    shim: Path


_INSTALLED: list[InstalledWheel] = []


def installed_wheel() -> InstalledWheel:
    """Build and install the compiled wheel once per run (a temporary directory, removed
    when the run ends). Raises subprocess.CalledProcessError when the build fails."""
    if _INSTALLED:
        return _INSTALLED[0]
    import atexit
    import shutil
    import tempfile

    base = Path(tempfile.mkdtemp(prefix="millblocks-bench-wheel-"))
    atexit.register(shutil.rmtree, base, True)
    dist = base / "dist"
    build = [sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "--no-build-isolation"]
    subprocess.run(
        [*build, "-w", str(dist), str(ROOT)],
        env={**os.environ, "MILLBLOCKS_MYPYC": "1"},
        check=True,
        timeout=1200,
    )
    venv = base / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=300)
    (wheel,) = dist.glob("*.whl")
    pip = [str(venv / "bin" / "python"), "-m", "pip", "install", "--quiet"]
    subprocess.run([*pip, "-c", str(ROOT / "constraints.txt"), str(wheel)], check=True, timeout=900)
    shim = base / "shim"
    shim.mkdir()
    (shim / "bench").symlink_to(ROOT / "bench")
    _INSTALLED.append(InstalledWheel(venv / "bin", shim))
    return _INSTALLED[0]


def run_child(
    target: str,
    args: dict[str, Any],
    timeout: float,
    env: dict[str, str] | None = None,
    installed: InstalledWheel | None = None,
) -> Result:
    """Run `module:function(**args)` in a fresh interpreter (with `env` added to the
    environment); its result dict. With `installed`, the interpreter is that of the
    installed wheel, run outside the checkout (`app` from its site-packages).

    A failure or a time-out comes back as {"error": "..."}, never as an exception, so one
    broken case is reported in the table and the others still run. The child runs in its
    own process group, so a time-out also stops what it started (a gunicorn server).
    """
    if time.monotonic() > BUDGET.deadline:
        return {"error": "skipped: the run's time budget is used up"}
    limit = BUDGET.limit(timeout)
    python, cwd = (
        (sys.executable, ROOT)
        if installed is None
        else (str(installed.bin / "python"), installed.shim)
    )
    command = [python, "-m", "bench.child", target, json.dumps(args)]
    child = subprocess.Popen(
        command,
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        env=None if env is None else {**os.environ, **env},
    )
    try:
        stdout, stderr = child.communicate(timeout=limit)
    except subprocess.TimeoutExpired:
        _stop_group(child)
        return {"error": f"stopped after the {limit:.0f} s time limit"}
    lines = stdout.strip().splitlines()
    if child.returncode != 0 or not lines:
        errors = [line for line in stderr.strip().splitlines() if line.strip()]
        return {"error": errors[-1] if errors else f"exit status {child.returncode}"}
    result: Result = json.loads(lines[-1])
    return result


def _stop_group(child: subprocess.Popen[str]) -> None:
    """Stop a timed-out child and everything in its process group (ours: it leads it)."""
    for sig, wait in ((signal.SIGTERM, 15.0), (signal.SIGKILL, 10.0)):
        try:
            os.killpg(child.pid, sig)
        except ProcessLookupError:
            break
        try:
            child.communicate(timeout=wait)
            break
        except subprocess.TimeoutExpired:
            continue


# -- the machine ----------------------------------------------------------------------------


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def _memory() -> str:
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal"):
                return f"{int(line.split()[1]) / 1024 / 1024:.1f} GiB"
    except OSError:
        pass
    return "unknown"


def git_commit() -> str:
    try:
        head = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + (" (with uncommitted changes)" if dirty else "")


def version(package: str) -> str:
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return "not installed"


def machine_lines() -> list[str]:
    """Markdown bullet lines describing this machine and run."""
    packages = ", ".join(
        f"{name} {version(name)}"
        for name in ("Flask", "SQLAlchemy", "gunicorn", "svgwrite", "psycopg", "pygcode")
    )
    return [
        f"- Date: {datetime.now(UTC):%Y-%m-%d %H:%M} UTC",
        f"- Machine: {_cpu_model()}, {os.cpu_count()} cores, {_memory()} memory",
        f"- System: {platform.platform()}",
        f"- Python: {platform.python_implementation()} {platform.python_version()}",
        f"- Packages: {packages}",
        f"- Code: commit {git_commit()}",
    ]


# -- formats --------------------------------------------------------------------------------


def fmt_count(n: float) -> str:
    """1234567 → `1 234 567` (thin groups, as the docs write numbers)."""
    return f"{n:,.0f}".replace(",", " ")


def fmt_rate(per_second: float) -> str:
    return f"{fmt_count(per_second)}/s"


def fmt_bytes(n: float) -> str:
    for unit, size in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if abs(n) >= size:
            return f"{n / size:.1f} {unit}"
    return f"{n:.0f} B"


def fmt_seconds(seconds: float) -> str:
    if seconds != seconds:  # NaN
        return "–"
    if seconds < 1:
        return f"{seconds * 1000:.1f} ms"
    return f"{seconds:.2f} s"


def fmt_ratio(ratio: float) -> str:
    if ratio != ratio:
        return "–"
    return f"{ratio:.2f}×" if ratio < 10 else f"{ratio:.0f}×"


def table(header: Sequence[str], rows: Iterable[Sequence[str]]) -> list[str]:
    """A Markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return lines


@dataclass
class Section:
    """One benchmark's part of docs/benchmarks.md."""

    title: str
    lines: list[str] = field(default_factory=list)
    summary: list[tuple[str, str, str, str]] = field(default_factory=list)

    def text(self) -> str:
        return "\n".join([f"### {self.title}", "", *self.lines, ""])

    def target(self, what: str, target: str, measured: str, ratio: str) -> None:
        """A line of the targets table at the top of the report."""
        self.summary.append((what, target, measured, ratio))


# -- documents ------------------------------------------------------------------------------


def replace_between(path: Path, key: str, generated: str, preamble: str = "") -> None:
    """Put `generated` between `<!-- key:begin -->` and `<!-- key:end -->` in `path`.

    Everything outside the markers (the hand-written analysis) is kept; a missing file or a
    file without the markers gets them appended after `preamble`.
    """
    begin, end = f"<!-- {key}:begin -->", f"<!-- {key}:end -->"
    block = f"{begin}\n{generated.rstrip()}\n{end}"
    text = path.read_text() if path.exists() else preamble
    if begin in text and end in text:
        head, rest = text.split(begin, 1)
        tail = rest.split(end, 1)[1]
        text = head + block + tail
    else:
        text = text.rstrip() + ("\n\n" if text.strip() else "") + block + "\n"
    path.write_text(text)
