"""Look at an HTML bake report in a real browser: a screenshot, and a check that nothing overflows.

Uses headless Chromium (Debian: ``apt-get install chromium``). The screenshot is what a person
sees; the overflow check loads a copy of the page with a small script appended that lists every
element whose content is wider than its box (tables inside their scroll boxes excepted, they
scroll by design) and whether the page itself scrolls sideways.

    clothtool bake examples/skirt/walk.toml -o out/walk.usdc --report out/walk.html
    python benchmarks/report_screenshot.py out/walk.html -o out/walk.png               # 1280x2400
    python benchmarks/report_screenshot.py out/walk.html -o out/walk.png --size 800x3000

Exit code 1 (with the offending elements listed) when something overflows or Chromium fails.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from html.parser import HTMLParser
from pathlib import Path

CHROMIUM_FLAGS = (
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync", "--hide-scrollbars",
)

# Appended to a copy of the page: records overflowing elements in <body data-overflow="[...]">.
OVERFLOW_PROBE = """<script>
(() => {
  const bad = [];
  const root = document.documentElement;
  if (root.scrollWidth > root.clientWidth + 1) bad.push(`page: ${root.scrollWidth}px wide in a ${root.clientWidth}px window`);
  for (const el of document.body.querySelectorAll("*")) {
    if (el.closest("svg") || el.tagName === "SCRIPT") continue;
    const box = el.parentElement.closest(".scroll");
    if (box) continue;  // inside a scroll box: wide content scrolls there by design
    if (!el.classList.contains("scroll") && el.clientWidth > 0 && el.scrollWidth > el.clientWidth + 1)
      bad.push(`${el.tagName.toLowerCase()}: ${el.textContent.trim().slice(0, 80)}`);
  }
  document.body.setAttribute("data-overflow", JSON.stringify(bad));
})();
</script>"""


def find_chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")


def _run_chromium(args: list[str], chromium: str | None) -> subprocess.CompletedProcess:
    binary = chromium or find_chromium()
    if binary is None:
        raise RuntimeError("no Chromium found; install it (Debian: apt-get install chromium) or pass --chromium PATH")
    with tempfile.TemporaryDirectory(prefix="clothtool-chromium-") as profile:
        return subprocess.run(
            [binary, *CHROMIUM_FLAGS, f"--user-data-dir={profile}", *args],
            capture_output=True, text=True, timeout=120,
        )


def screenshot(page: Path, png: Path, size: tuple[int, int] = (1280, 2400), chromium: str | None = None) -> Path:
    """Render ``page`` at ``size`` (width, height in CSS pixels) into ``png``."""
    png = Path(png).resolve()
    png.unlink(missing_ok=True)
    done = _run_chromium([f"--screenshot={png}", f"--window-size={size[0]},{size[1]}", Path(page).resolve().as_uri()], chromium)
    if done.returncode != 0 or not png.exists():
        raise RuntimeError(f"chromium failed to screenshot {page} (exit {done.returncode}): {done.stderr.strip()[-500:]}")
    return png


class _OverflowAttribute(HTMLParser):
    def __init__(self):
        super().__init__()
        self.value: str | None = None

    def handle_starttag(self, tag, attrs):
        if tag == "body":
            self.value = dict(attrs).get("data-overflow")


def overflowing(page: Path, width: int = 1280, chromium: str | None = None) -> list[str]:
    """Elements of ``page`` whose content overflows their box in a ``width``-pixel window."""
    text = Path(page).read_text(encoding="utf-8")
    with tempfile.TemporaryDirectory(prefix="clothtool-overflow-") as folder:
        probe = Path(folder) / "page.html"
        probe.write_text(text.replace("</body>", OVERFLOW_PROBE + "</body>"), encoding="utf-8")
        done = _run_chromium([f"--window-size={width},1000", "--dump-dom", probe.as_uri()], chromium)
    parser = _OverflowAttribute()
    parser.feed(done.stdout)
    if done.returncode != 0 or parser.value is None:
        raise RuntimeError(f"chromium failed to load {page} (exit {done.returncode}): {done.stderr.strip()[-500:]}")
    return json.loads(parser.value)


def _size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not WIDTHxHEIGHT, e.g. 1280x2400") from None
    return width, height


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("page", type=Path, help="the report's .html file")
    parser.add_argument("-o", "--output", type=Path, required=True, help="PNG to write")
    parser.add_argument("--size", type=_size, default=(1280, 2400), help="window WIDTHxHEIGHT [1280x2400]")
    parser.add_argument("--chromium", help="browser binary [chromium on PATH]")
    args = parser.parse_args(argv)
    if not args.page.is_file():
        print(f"error: {args.page}: no such file; give the .html written by clothtool bake --report", file=sys.stderr)
        return 1
    try:
        png = screenshot(args.page, args.output, args.size, args.chromium)
        problems = overflowing(args.page, args.size[0], args.chromium)
    except (RuntimeError, subprocess.TimeoutExpired) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    print(f"{png.name}: {args.size[0]}x{args.size[1]} screenshot of {args.page.name}")
    for problem in problems:
        print(f"overflows its box: {problem}", file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
