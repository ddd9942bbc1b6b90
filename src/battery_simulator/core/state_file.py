"""A battery's state in a JSON file (``state_file``): read at start, written atomically (no ROS import)."""
import json
import os


def read_state_file(path):
    """The saved state in ``path``, or None when there is no file; OSError/ValueError when it cannot be read."""
    if not path or not os.path.exists(path):
        return None
    with open(path, encoding='utf-8') as stream:
        return json.load(stream)


def write_state_file(path, state):
    """Write ``state`` to ``path`` through a temporary file: never a half-written file. OSError on failure."""
    temporary = path + '.tmp'
    with open(temporary, 'w', encoding='utf-8') as stream:
        json.dump(state, stream, indent=1)
    os.replace(temporary, path)
