"""clothtool._jit's device twins: LLVM IR for their callers only (no module passes or machine
code of their own), cached as bitcode that a caller compiled in a later process links."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

from clothtool._jit import _TwinLibrary, kernel

REPO = Path(__file__).resolve().parents[2]

HELPERS = '''
import numpy as np
from clothtool._jit import kernel


@kernel(device=True)
def hypot3(x, y, z):
    return np.sqrt(x * x + y * y + z * z)


@kernel
def lengths(rows, out):
    for i in range(rows.shape[0]):
        out[i] = hypot3(rows[i, 0], rows[i, 1], rows[i, 2])


@kernel
def longest(rows):
    best = 0.0
    for i in range(rows.shape[0]):
        best = max(best, hypot3(rows[i, 0], rows[i, 1], rows[i, 2]))
    return best
'''

RUN = '''
import json, sys
import numpy as np
import helpers
rows = np.array([[3.0, 4.0, 12.0], [1.0, 2.0, 2.0]])
if sys.argv[1] == "lengths":
    out = np.empty(2)
    helpers.lengths(rows, out)
    value = out.tolist()
else:
    value = helpers.longest(rows)
twin = helpers.hypot3.twin
print(json.dumps({"value": value, "twin_hits": sum(twin.stats.cache_hits.values()),
                  "twin_misses": sum(twin.stats.cache_misses.values())}))
'''


@kernel(device=True)
def _double(x):
    return 2.0 * x


@kernel
def _twice_plus_one(x):
    return _double(x) + 1.0


def test_a_twin_compiles_into_a_twin_library_and_its_callers_run_it():
    assert _twice_plus_one(1.5) == 4.0
    assert _double(1.5) == 3.0  # a call from Python compiles the dispatcher with its wrappers
    (twin_result,) = _double.twin.overloads.values()
    assert isinstance(twin_result.library, _TwinLibrary)
    (caller_result,) = _twice_plus_one.overloads.values()
    assert not isinstance(caller_result.library, _TwinLibrary)


def _run(tmp_path: Path, which: str) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith("CLOTHTOOL_")}
    env["CLOTHTOOL_CACHE_DIR"] = str(tmp_path / "cache")
    env["PYTHONPATH"] = os.pathsep.join([str(tmp_path), str(REPO), env.get("PYTHONPATH", "")])
    result = subprocess.run([sys.executable, "-c", RUN, which], env=env, capture_output=True, text=True, check=True)
    return json.loads(result.stdout.splitlines()[-1])


def test_a_caller_compiled_in_a_later_process_links_the_cached_twin(tmp_path):
    (tmp_path / "helpers.py").write_text(textwrap.dedent(HELPERS))
    first = _run(tmp_path, "lengths")
    assert first["value"] == [13.0, 3.0]
    assert (first["twin_hits"], first["twin_misses"]) == (0, 1)
    second = _run(tmp_path, "longest")  # a new caller: compiles, the twin comes from the cache
    assert second["value"] == 13.0
    assert (second["twin_hits"], second["twin_misses"]) == (1, 0)
    again = _run(tmp_path, "lengths")  # everything cached: the twin is not even looked up
    assert again["value"] == [13.0, 3.0]
    assert (again["twin_hits"], again["twin_misses"]) == (0, 0)
