"""Set-up of the batch's fork server, done on import: only the fork server imports this
module (it is last in `cosim.study.pool.PRELOAD`); the command's own process never does.

A worker forked by the fork server starts with the SIGINT handler the server had when it
imported its preload list (multiprocessing.forkserver restores it in each child) and keeps
the server's SIGHUP disposition. Ignored here, a terminal's Ctrl-C or SIGHUP (sent to the
whole process group) finds no worker in a moment where it could die with a traceback,
not even one still unpickling its task; the parent ends every worker itself
(`cosim.study.pool._end_pool`)."""

import signal

signal.signal(signal.SIGINT, signal.SIG_IGN)
if hasattr(signal, "SIGHUP"):
    signal.signal(signal.SIGHUP, signal.SIG_IGN)
