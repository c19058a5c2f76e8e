"""Where outputs go and how they get there: one place that resolves, checks and commits every output.

The contract (README "Rules"):

* Every path a command writes must differ from every path it reads and from
  every other output.  Paths are compared after resolving them and by inode, so
  a symlink or a hard link to an input *is* that input.  Character devices and
  sockets (``/dev/null``, a terminal) are exempt: reading and writing them does
  not destroy anything.
* A regular file (or a new name) is written atomically: a temporary file
  ``.NAME.anglesmooth-XXXXXXXX<suffix>`` in the directory of the file it
  replaces, fsynced, given the mode (minus set-uid / set-gid) and, when
  permitted, the owner and group of the file it replaces (a new file: 0666
  minus the umask), then renamed over it.  A symlink is followed: its target
  is replaced and the link stays.  Other hard links of a replaced file keep
  the old content (the rename gives the name a new inode).
* Anything that is not a regular file (character or block device, FIFO,
  socket, ``/dev/stdout``, ``/dev/fd/N``) is written *into*, as a stream, and
  never replaced or removed.
* Inside :class:`Outputs` (the command line uses one per command), writes are
  staged and committed together by :meth:`Outputs.commit`: streams first, then
  the renames (a SIGINT / SIGTERM arriving during the renames is acted on
  after them).  An error or signal before the commit leaves no output and no
  temporary file.
* Every temporary file and directory is listed while it exists
  (:mod:`.temps`): :func:`remove_temporaries` removes them all, for a process
  terminated while another of its threads writes (a Dask worker).
* Temporary files left by a killed process (SIGKILL) are found by
  :func:`stale_temporaries` (the command line mentions them, it does not
  delete them: another run may still own them).

Writes to a stream loop until every byte is written (a non-blocking stream is
waited for with ``select``); a closed reader raises ``BrokenPipeError``.

Modules: ``temps`` (the temporaries of unfinished writes), ``stdio`` (standard
descriptors), ``targets`` (resolving and checking outputs) and ``staging``
(writing, :class:`Outputs`), each importing only the ones before it; everything is imported here: ``from anglesmooth._paths import X``.
"""

from __future__ import annotations

from .staging import Outputs, active, atomic_write, write_all
from .stdio import STDIO, carries_stdout, mark_closed_std_fds, std_fd_closed
from .targets import TAG, OutputConflictError, Target, check_outputs, glob_escape, resolve_output, stale_temporaries
from .temps import remove_temporaries, remove_temporaries_on_sigterm, temporary_directory

__all__ = ["OutputConflictError", "Outputs", "Target", "active", "atomic_write", "carries_stdout", "check_outputs",
           "mark_closed_std_fds", "remove_temporaries", "remove_temporaries_on_sigterm", "resolve_output", "stale_temporaries", "std_fd_closed",
           "temporary_directory", "write_all"]
