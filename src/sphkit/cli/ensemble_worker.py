"""Preload of the workers of ``sphkit dataset``'s and ``sphkit sweep``'s local Dask cluster.

Ctrl-C in a terminal reaches the whole process group, the cluster's worker processes too; the
command itself stops the cluster (and exits 130), so its workers ignore SIGINT instead of each
printing a KeyboardInterrupt traceback.
"""

from __future__ import annotations

import signal
import threading

if threading.current_thread() is threading.main_thread():
    signal.signal(signal.SIGINT, signal.SIG_IGN)
