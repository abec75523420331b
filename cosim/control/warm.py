"""Importing this module compiles every numba function of the package (or loads it
from numba's on-disk cache) in the importing process: it loads the modules with
compiled functions (the closed loop, the collision check, the new follower's
prediction, the loop's per-step geometry in cosim.run.proximity, the road frame's
conversions in cosim.road.frame; each registers its
warm-up with cosim.compiled) and runs `warm_up`.

For a fork server's preload list (`cosim.study.pool.PRELOAD`): the server pays numba's
start-up once (about 1.2 s: import, compiler set-up, cached code) and every run
forked from it starts with the compiled code in memory. Measured: a forked run of
paper case 5.1 takes 1.45 s without this module in the preload list, 0.28 s with it.
"""

from __future__ import annotations

from cosim.compiled import load_compiled_modules, warm_up

load_compiled_modules()
warm_up()

__all__ = ["warm_up"]
