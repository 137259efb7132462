"""Which kernel runs behind the body and finger stages: the one place where a size
picks one, with the measurements that set each threshold.

Two kernels do the same tests with the same answers: numpy's (``body``'s and
``fingers``' own functions) and the compiled loops (``_compiled``, numba, a
dependency of wsgrasp). The compiled loops are faster at every size, but loading
them costs a process 0.3-1.5 s once (numba's import, 0.27-0.48 s measured on this
project's 2-core machine with numba 0.68.1, and the first call of any compiled
function, cached or not, another 0.3-0.4 s). So:

- from ``COMPILED_FROM`` (candidate, point) pairs on, a search loads them at
  once: the Franka hand's dense search (512,000 candidates) takes 0.24 s
  compiled, 0.7 s with numpy;
- below, a process runs numpy's kernels until it has done
  ``SMALL_BEFORE_LOADING`` searches of ``SMALL_FROM`` pairs or more, or the
  loops are loaded: on the Franka hand's Table I search the loops take under
  half the time of numpy's (body and finger tests 2.8 -> 1.2 ms), so a process
  that plans a scene or two never loads them and one that plans many pays once;
- ``WSGRASP_NUMBA=0`` (or numba missing) leaves numpy's kernels everywhere.

The clutter pipeline's test of the fingers' closing paths against neighbours
(``wsgrasp.neighbours``) and the closing sweeps' reach test (``sweeps``) run
compiled in a process whose searches have loaded the loops, and with numpy's
passes otherwise: the same answers either way (the reach test of the Allegro
hand's dense search: 11 ms compiled, 44 ms with numpy, medians of 15
alternated).

From ``COMPILED_FROM`` pairs on the compiled body loop also reads the object's
nearest-point grid (3.4 ms to build for 800 points) and the finger loop reads the
points in space order (the Allegro's dense counts 20 % faster; sorting costs
more than it saves on a few hundred candidates, 0.13 ms of the Franka hand's
Table I search).

Within numpy's body kernel, points sorted along a gripper axis per orientation
(``body.Slabs``) let the test read only the points in a body's slab; sorting
pays from ``SLAB_FROM`` candidates per orientation on (the Franka hand's default
search, numpy's kernels: 4.8 ms with the slabs, 6.7 ms without). numpy's finger
kernel reads every point: its slab lookup, measured side by side over 21 runs
each, took the Franka hand's default search 4.72 ms against 4.76 without and
the Allegro hand's 18.8 against 18.6; its dense searches (numba turned off) 767
against 968 ms and 4,962 against 4,185 ms.
"""

from __future__ import annotations

from dataclasses import dataclass

from wsgrasp.planning import _compiled

__all__ = ["Kernels", "choose_kernels"]

COMPILED_FROM = 1_000_000
SMALL_FROM = 20_000
SMALL_BEFORE_LOADING = 3
SLAB_FROM = 2

_small_searches = 0


@dataclass(frozen=True)
class Kernels:
    """The kernels of one search.

    Attributes
    ----------
    compiled : bool
        The compiled loops (else numpy's kernels).
    dense : bool
        A dense search: the compiled body loop's nearest-point hints and the
        finger loop's points in space order.
    """

    compiled: bool
    dense: bool


def choose_kernels(pairs: int, search: bool = True) -> Kernels:
    """The kernels of an evaluation of ``pairs`` (candidate, point) pairs (see
    the module docstring). A ``search`` (a candidate set, not a few poses
    checked again) counts among the process's small searches."""
    return Kernels(_use_compiled(pairs, search), pairs >= COMPILED_FROM)


def _use_compiled(pairs: int, search: bool) -> bool:
    global _small_searches
    if not _compiled.available():
        return False
    if pairs >= COMPILED_FROM or _compiled.loaded():
        return True
    if pairs < SMALL_FROM or not search:  # too few to be worth loading for
        return False
    _small_searches += 1
    return _small_searches > SMALL_BEFORE_LOADING
