"""One battery per name on this machine, decided at once: a registry file per ROS domain (and user) that every
battery process of the machine reads and writes under an exclusive lock, before it publishes its claim on
/battery_claims (ros2/startup.py's BatteryClaim, which covers other machines through DDS).

DDS discovery on a busy machine can take longer than any fixed wait (two battery_sim started together on a
machine at load 12 did not see each other's claims for 20 s), so a duplicate on the same machine is refused
by this file first, before it says it is ready. An entry of a process that no longer runs (SIGKILL) is
dropped by the next reader: nothing stale blocks a restart.
"""
import contextlib
import fcntl
import json
import os
import tempfile


def registry_path():
    domain = os.environ.get('ROS_DOMAIN_ID', '0') or '0'
    return os.path.join(tempfile.gettempdir(), 'battery_simulator_batteries_uid%d_domain%s.json' % (os.getuid(), domain))


def _process_start(pid):
    """The start time of process ``pid`` (clock ticks since boot), or None if it does not run (a zombie, killed
    and not yet reaped, does not): a pid used again by another process is not taken for the one that registered."""
    try:
        with open('/proc/%d/stat' % pid, encoding='ascii', errors='replace') as stream:
            fields = stream.read().rsplit(')', 1)[1].split()
        return None if fields[0] in ('Z', 'X') else int(fields[19])
    except (OSError, IndexError, ValueError):
        return None


@contextlib.contextmanager
def _locked_registry(path):
    """The registry's entries {pid: entry} of running processes, under an exclusive lock; written back."""
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o600)
    with os.fdopen(fd, 'r+', encoding='utf-8') as stream:
        fcntl.flock(stream, fcntl.LOCK_EX)
        try:
            entries = json.loads(stream.read() or '{}')
            if not isinstance(entries, dict):
                entries = {}
        except ValueError:
            entries = {}
        live = {pid: entry for pid, entry in entries.items()
                if isinstance(entry, dict) and pid.isdigit() and _process_start(int(pid)) == entry.get('start')}
        yield live
        stream.seek(0)
        stream.truncate()
        stream.write(json.dumps(live))
        stream.flush()


def register(names, what, path=None):
    """Register this process as serving ``names`` (namespaces): None, or (the holder's line, its pid, names
    taken) when another running process of this machine already serves one of them (nothing registered)."""
    path = path or registry_path()
    try:
        with _locked_registry(path) as live:
            wanted = set(names)
            for pid, entry in sorted(live.items()):
                taken = sorted(wanted.intersection(entry.get('names', ())))
                if taken and int(pid) != os.getpid():
                    return entry.get('node', '?'), int(pid), taken
            live[str(os.getpid())] = {'names': sorted(wanted), 'node': what, 'start': _process_start(os.getpid())}
    except OSError:
        return None   # no registry (a read-only temp directory): DDS claims alone decide
    return None


def unregister(path=None):
    """Drop this process's entry (at its end; a killed process's entry is dropped by the next reader)."""
    with contextlib.suppress(OSError):
        with _locked_registry(path or registry_path()) as live:
            live.pop(str(os.getpid()), None)
