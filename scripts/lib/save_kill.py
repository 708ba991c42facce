#!/usr/bin/env python3
"""Times a map save from outside and SIGKILLs it at a chosen point (scripts/crash-campaign.sh).

The console's save is observed without any hook in vilma: the console's own output lines
(`> save ...` is echoed and flushed before the save starts, `(save: X s)` after it ends) read
from a pipe, and inotify on the map folder: the new generation folder appearing under
missions/<id>/ (the first step of the write sequence) and manifest.yaml renamed into place (the
commit point, mapstore/src/map_io.cpp). Times are in ms after the `> save` line.

  save_kill.py timing MAP -- CMD...          runs CMD to the end, prints the save's timeline
  save_kill.py kill MAP DELAY_MS -- CMD...   SIGKILLs CMD DELAY_MS after the `> save` line

The killer runs at SCHED_FIFO when allowed (its timer then fires within 0.1 ms), CMD with the
caller's scheduling policy and nice value (SCHED_RESET_ON_FORK).

Both print one line of `key=value` fields. After a kill, the inotify events still queued are
read once the process is dead, so `committed=1` means the manifest's rename happened before the
process died, whatever the timing: the map must then load as the new generation, and as the
previous one otherwise. `data_files` counts the new generation's data files in place (renamed
from their temporary names) at the kill, `temp_files` those still under a temporary name.
"""
import ctypes
import os
import re
import select
import signal
import struct
import subprocess
import sys
import time

IN_CREATE = 0x100
IN_MOVED_TO = 0x80
IN_ONLYDIR = 0x1000000
IN_NONBLOCK = 0o4000
IN_CLOEXEC = 0o2000000

START = re.compile(rb"^> save\b", re.M)
END = re.compile(rb"^\s*\(save: ", re.M)
GENERATION = re.compile(r"^g[0-9]{6}$")


class Watcher:
    """inotify on MAP (manifest.yaml renamed in) and each MAP/missions/<id> (a new g folder)."""

    def __init__(self, map_dir):
        self.libc = ctypes.CDLL(None, use_errno=True)
        self.fd = self.libc.inotify_init1(IN_NONBLOCK | IN_CLOEXEC)
        if self.fd < 0:
            raise OSError(ctypes.get_errno(), "inotify_init1")
        self.map_dir = map_dir
        self.watches = {}
        self.add(map_dir, IN_MOVED_TO)
        missions = os.path.join(map_dir, "missions")
        for name in sorted(os.listdir(missions)):
            self.add(os.path.join(missions, name), IN_CREATE)
        self.existing = {os.path.join(d, g) for d in self.watches.values()
                         for g in os.listdir(d) if GENERATION.match(g)}
        self.new_generation_dirs = []
        self.t_generation = None
        self.t_commit = None

    def add(self, path, mask):
        wd = self.libc.inotify_add_watch(self.fd, path.encode(), mask | IN_ONLYDIR)
        if wd < 0:
            raise OSError(ctypes.get_errno(), "inotify_add_watch " + path)
        self.watches[wd] = path

    def read(self, now):
        try:
            buf = os.read(self.fd, 65536)
        except BlockingIOError:
            return
        at = 0
        while at + 16 <= len(buf):
            wd, mask, _, length = struct.unpack_from("iIII", buf, at)
            name = buf[at + 16:at + 16 + length].split(b"\0", 1)[0].decode()
            at += 16 + length
            folder = self.watches.get(wd)
            if folder is None:
                continue
            path = os.path.join(folder, name)
            if folder == self.map_dir and mask & IN_MOVED_TO and name == "manifest.yaml":
                if self.t_commit is None:
                    self.t_commit = now
            elif mask & IN_CREATE and GENERATION.match(name) and path not in self.existing:
                self.new_generation_dirs.append(path)
                if self.t_generation is None:
                    self.t_generation = now


def ms(t, t0):
    return "-" if t is None or t0 is None else "%.1f" % ((t - t0) * 1000.0)


def main():
    args = sys.argv[1:]
    if "--" not in args or len(args) < 3 or args[0] not in ("timing", "kill"):
        sys.exit(__doc__)
    split = args.index("--")
    mode, map_dir = args[0], args[1]
    delay_ms = float(args[2]) if mode == "kill" else None
    command = args[split + 1:]
    log = open(map_dir.rstrip("/") + ".log", "wb") if os.environ.get("SAVE_KILL_LOG") is None \
        else open(os.environ["SAVE_KILL_LOG"], "wb")

    # The timer's precision: under load a nice -10 process overshot a 1-30 ms select() timeout
    # by up to 6 ms (p90 4.5 ms, load 4.5 on this 2-core VM), SCHED_FIFO by 0.1 ms. The killer
    # mostly sleeps; SCHED_RESET_ON_FORK gives the console the normal policy and the
    # campaign's nice value. Without the privilege it keeps the normal policy (realtime=0).
    realtime = 1
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO | os.SCHED_RESET_ON_FORK, os.sched_param(10))
    except (PermissionError, AttributeError, OSError):
        realtime = 0
    watcher = Watcher(map_dir)
    child = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    out_fd = child.stdout.fileno()
    output = b""
    t_start = t_end = t_kill = None
    eof = False
    while not eof:
        timeout = None
        if t_start is not None and delay_ms is not None and t_kill is None:
            timeout = max(0.0, t_start + delay_ms / 1000.0 - time.monotonic())
            if timeout == 0.0:
                t_kill = time.monotonic()
                os.kill(child.pid, signal.SIGKILL)
                timeout = None
        readable, _, _ = select.select([out_fd, watcher.fd], [], [], timeout)
        now = time.monotonic()
        if watcher.fd in readable:
            watcher.read(now)
        if out_fd in readable:
            chunk = os.read(out_fd, 65536)
            if not chunk:
                eof = True
            log.write(chunk)
            output += chunk
            if t_start is None and START.search(output):
                t_start = now
            if t_end is None and END.search(output):
                t_end = now
    returncode = child.wait()
    t_exit = time.monotonic()
    watcher.read(t_exit)  # events of the last moments before the process died
    log.close()

    generation = watcher.new_generation_dirs[0] if watcher.new_generation_dirs else None
    data_files = temp_files = 0
    if generation is not None and os.path.isdir(generation):
        for name in os.listdir(generation):
            if name.startswith("."):
                temp_files += 1
            else:
                data_files += 1
    fields = [
        ("mode", mode),
        ("exit", returncode),
        ("save_started", int(t_start is not None)),
        ("generation_ms", ms(watcher.t_generation, t_start)),
        ("commit_ms", ms(watcher.t_commit, t_start)),
        ("save_end_ms", ms(t_end, t_start)),
        ("exit_ms", ms(t_exit, t_start)),
    ]
    if mode == "kill":
        fields += [
            ("delay_ms", "%.1f" % delay_ms),
            ("kill_ms", ms(t_kill, t_start)),
            # The save had ended (its line printed) before the kill: the kill hit the exit.
            ("killed", int(t_kill is not None and returncode == -signal.SIGKILL)),
        ]
        # Where the kill landed: before the new generation's folder, while writing it (before
        # the commit), between the commit and the end of the save (removal of the previous
        # generation), or after the save had ended (the process's exit, or no kill at all).
        if t_kill is None or returncode != -signal.SIGKILL or (t_end is not None and t_end <= t_kill):
            phase = "after_save"
        elif watcher.t_commit is not None:
            phase = "after_commit"
        elif watcher.t_generation is None:
            phase = "before_generation"
        else:
            phase = "writing"
        fields.append(("phase", phase))
    fields += [
        ("committed", int(watcher.t_commit is not None)),
        ("realtime", realtime),
        ("data_files", data_files),
        ("temp_files", temp_files),
    ]
    print(" ".join("%s=%s" % kv for kv in fields))


if __name__ == "__main__":
    main()
