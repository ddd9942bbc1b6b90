"""tools/summarize_test_results.py: real cases only, and no silent zero."""
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / 'tools' / 'summarize_test_results.py'


def suite(tests, failures=0):
    return '<testsuite tests="%d" failures="%d" errors="0" skipped="0"></testsuite>' % (tests, failures)


def summarize(tmp_path, files):
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    result = subprocess.run([sys.executable, str(SCRIPT), str(tmp_path)], capture_output=True, text=True)
    return result.returncode, result.stdout


def test_wrappers_do_not_count_but_their_failures_do(tmp_path):
    code, out = summarize(tmp_path, {'rostest-a.xml': suite(1), 'rosunit-a.xml': suite(3), 'pytest-unit.xml': suite(5)})
    assert code == 0 and '8 passed, 0 failed' in out, out
    code, out = summarize(tmp_path, {'rostest-a.xml': suite(1, failures=1)})
    assert code == 1 and '7 passed, 1 failed' in out, out


def test_a_file_with_zero_cases_fails_the_run(tmp_path):
    code, out = summarize(tmp_path, {'rosunit-a.xml': suite(3), 'rosunit-empty.xml': suite(0)})
    assert code == 1 and 'ran no test case' in out, out


def test_no_results_at_all_fail(tmp_path):
    code, out = summarize(tmp_path, {})
    assert code == 1 and 'no test ran' in out
