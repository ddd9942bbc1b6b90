"""Every path of this repository that a doc, a docstring, a comment or a tool names exists (issue 40, item 13).

The layout moved (``battery/`` and ``ros/`` became ``ros1/``, ``ros2/`` and ``core/``) and the words did not
follow: tools/mutation.sh mutated a file that no longer existed, and docstrings sent readers to modules
that were gone. This test reads the docs (``*.md``), the sources and tests (``*.py``), the tools and scripts,
the launch files, and checks each path-like word:

- a file (``a/b.py``, ``core/pack.py``, ``docs/model.md``) must exist as written from the repository's
  root, from the naming file's own directory, or as the end of a path of the repository
  (``core/pack.py`` is ``src/battery_simulator/core/pack.py``);
- a directory named in a list (``(battery/, robot/, web/)``) or in backticks (```ros2/```) must be a
  directory of the repository.

What is not of this repository is not checked: absolute and home paths, URLs, names with placeholders
(``<name>/``, ``$VAR/``), the build tree (``build/``, made by tools/build.sh), and FOREIGN below.
"""
import ast
import os
import re

import pytest

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..'))
PACKAGE = os.path.join(ROOT, 'src', 'battery_simulator')
#: trees that are not the repository's sources (made by the build, the tests or tools)
SKIPPED_DIRS = {'.git', 'build', 'devel', 'install', 'log', '__pycache__', '.pytest_cache', 'mutants',
                'node_modules', '.ros2'}
#: words that name a path, but of another repository or of the team's shared folder: each with why
FOREIGN = {
    'free_fleet_adapter/free_fleet_adapter/robot_adapter.py': "Open-RMF free_fleet's file (docs/consumers.md)",
    'shared/interface.md': 'the team\'s contract beside the clone, copied here as docs/interface.md',
}
#: endings of the file names that are checked (a word like ``geometry_msgs/Twist`` is a type, not a path)
EXTENSIONS = ('py', 'md', 'sh', 'launch', 'yaml', 'yml', 'test', 'msg', 'srv', 'action', 'cfg', 'txt',
              'json', 'csv', 'png', 'xml', 'bag', 'html', 'js', 'css', 'toml')
FILE_WORD = re.compile(r'(?<![\w./~$<>{}@:-])((?:[A-Za-z_][\w.-]*/)+[\w.-]+\.(?:%s))(?![\w/<>{}*])'
                       % '|'.join(EXTENSIONS))
#: a directory word: ``name/`` in backticks, or followed by a comma or a closing parenthesis
DIRECTORY_WORD = re.compile(r'(?:`([a-z][a-z0-9_]+)/`|(?<![\w./~$<>{}@:-])([a-z][a-z0-9_]+)/(?=[,)]))')


def repository_files():
    """Every file of the repository (relative, '/'-separated), the build tree left out."""
    found = []
    for directory, subdirectories, names in os.walk(ROOT):
        subdirectories[:] = [d for d in subdirectories if d not in SKIPPED_DIRS]
        relative = os.path.relpath(directory, ROOT)
        for name in names:
            found.append(name if relative == '.' else '%s/%s' % (relative.replace(os.sep, '/'), name))
    return found


FILES = repository_files()
THIS_FILE = 'test/package/test_paths_exist.py'   # it names stale paths on purpose (its own check's cases)
FILE_SET = set(FILES)
DIRECTORIES = {'/'.join(f.split('/')[:k]) for f in FILES for k in range(1, f.count('/') + 1)}


def naming_files():
    """The files whose words are read: docs, Python, shell, the tools and scripts, launch files, CMake."""
    return sorted(f for f in FILES if (f.endswith(('.md', '.py', '.sh', '.launch', '.test'))
                                       or f.startswith(('tools/', 'scripts/'))) and f != THIS_FILE)


def file_exists(word, naming_file):
    if word in FILE_SET:
        return True
    beside = os.path.normpath(os.path.join(os.path.dirname(naming_file), word)).replace(os.sep, '/')
    if beside in FILE_SET:
        return True
    return any(f.endswith('/' + word) for f in FILES)


def directory_exists(word):
    return word in DIRECTORIES or any(d.endswith('/' + word) for d in DIRECTORIES)


def missing_paths(text, naming_file):
    """[(line, word)] of the paths ``text`` names that the repository does not have."""
    missing = []
    for match in FILE_WORD.finditer(text):
        word = match.group(1)
        if word.startswith('build/') or word in FOREIGN or file_exists(word, naming_file):
            continue
        if word.startswith('battery_simulator/') and file_exists(word[len('battery_simulator/'):], naming_file):
            continue   # the clone's own directory: battery_simulator/tools/install_dependencies.sh
        missing.append((text.count('\n', 0, match.start()) + 1, word))
    for match in DIRECTORY_WORD.finditer(text):
        word = match.group(1) or match.group(2)
        if word in SKIPPED_DIRS or directory_exists(word):
            continue
        missing.append((text.count('\n', 0, match.start()) + 1, word + '/'))
    return missing


def test_every_path_named_in_a_doc_a_docstring_or_a_tool_exists():
    stale = []
    for name in naming_files():
        try:
            with open(os.path.join(ROOT, name), encoding='utf-8') as stream:
                text = stream.read()
        except (UnicodeDecodeError, OSError):
            continue   # a binary file in tools/ or scripts/
        stale += ['%s:%d names %s' % (name, line, word) for line, word in missing_paths(text, name)]
    assert not stale, 'paths that do not exist:\n' + '\n'.join(stale)


@pytest.mark.parametrize('text, expected', [
    ('see battery/robot_log.py for rospy', [(1, 'battery/robot_log.py')]),
    ('the nodes (`battery/`) and (`ros2/`)', [(1, 'battery/')]),
    ('imported by (battery/, robot/, web/)', [(1, 'battery/')]),
    ('tools/mutation.sh mutates src/battery_simulator/battery/battery_state.py',
     [(1, 'src/battery_simulator/battery/battery_state.py')]),
    ('core/pack.py, docs/model.md, ros1/startup.py, test/conftest.py', []),
    ('geometry_msgs/Twist on /robot1/battery_status, <name>/battery_simulator, ~/.ros/log/x.py', []),
    ('https://example.com/a/b.py and build/devel/setup.bash', []),
])
def test_the_check_finds_a_stale_path_and_only_that(text, expected):
    """The check itself: it names the old layout's paths and passes today's, types, topics and URLs."""
    assert missing_paths(text, 'docs/x.md') == expected


def test_the_package_docstring_lists_exactly_its_subpackages():
    """src/battery_simulator/__init__.py says who each subpackage serves: it named ``battery`` and ``ros``
    after they had become ros1/ and ros2/."""
    with open(os.path.join(PACKAGE, '__init__.py'), encoding='utf-8') as stream:
        docstring = ast.get_docstring(ast.parse(stream.read()))
    listed = set(re.findall(r'^\s*- ``(\w+)``:', docstring, flags=re.MULTILINE))
    subpackages = {d for d in os.listdir(PACKAGE) if os.path.isfile(os.path.join(PACKAGE, d, '__init__.py'))}
    assert listed == subpackages, 'listed %s, the package has %s' % (sorted(listed), sorted(subpackages))
