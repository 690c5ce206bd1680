"""Time to reach a given error (``study --target-error``), per family of a study.

Each family's runs form a work-precision curve (wall time per simulated second against
error). The cheapest run whose error is at most the target answers "which setting"; the time
is interpolated in log-log between that run and the next cheaper one (whose error is above the
target), the straight line the plot draws between them. When the cheapest swept run already
meets the target the time is an upper bound: a cheaper setting, not swept, might too.
"""

from __future__ import annotations

import math


def _usable(row: dict, key: str) -> bool:
    return (
        not row["failed"] and math.isfinite(row[key]) and math.isfinite(row["wall_s_per_simulated_s"])
        and row["wall_s_per_simulated_s"] > 0
    )


def interpolate_time(t0: float, e0: float, t1: float, e1: float, target: float) -> float:
    """Time at which the log-log line through (t0, e0) and (t1, e1) has error ``target``
    (e0 > target >= e1 > 0)."""
    if e1 <= 0:
        return t1
    fraction = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0))
    return math.exp(math.log(t0) + fraction * (math.log(t1) - math.log(t0)))


def time_to_error(rows: list[dict], key: str, target: float) -> list[dict]:
    """Per family (in the rows' order): the cheapest run with |error| <= target and the
    interpolated wall time per simulated second to reach it, or the best error reached."""
    families: list[str] = []
    for row in rows:
        if row["family"] not in families:
            families.append(row["family"])
    answers = []
    for family in families:
        curve = sorted((r for r in rows if r["family"] == family and _usable(r, key)),
                       key=lambda r: r["wall_s_per_simulated_s"])
        answer = {"family": family, "reached": False, "run": None, "run_wall_s_per_simulated_s": None,
                  "wall_s_per_simulated_s": None, "bound": None,
                  "best_error": min((abs(r[key]) for r in curve), default=math.nan)}
        for i, row in enumerate(curve):
            error = abs(row[key])
            if error > target:
                continue
            time_ = row["wall_s_per_simulated_s"]
            answer.update(reached=True, run=row["label"], run_wall_s_per_simulated_s=time_)
            if i == 0:
                answer.update(wall_s_per_simulated_s=time_, bound="at most")
            else:
                before = curve[i - 1]
                answer.update(
                    wall_s_per_simulated_s=interpolate_time(
                        before["wall_s_per_simulated_s"], abs(before[key]), time_, error, target),
                    bound="interpolated",
                )
            break
        answers.append(answer)
    return answers
