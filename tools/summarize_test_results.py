#!/usr/bin/python3
"""Sum the JUnit XML files of a test run; print 'N passed, N failed, N skipped'.

Counts real test cases only: rostest's wrapper files (rostest-*.xml, one
entry standing for a whole .test file) add their failures (a test node that
crashed or ran out of time) but not their count. Exits 1 when a test failed
or errored, when a result file is unreadable, when any result file ran zero
cases, or when no test ran at all.
"""
import sys
import xml.etree.ElementTree as ElementTree
from pathlib import Path


def count(path):
    """(tests, failed, skipped) in one JUnit file (a testsuite or testsuites root)."""
    root = ElementTree.parse(path).getroot()
    suites = [root] if root.tag == 'testsuite' else root.findall('testsuite')
    tests = failed = skipped = 0
    for suite in suites:
        tests += int(suite.get('tests', 0))
        failed += int(suite.get('failures', 0)) + int(suite.get('errors', 0))
        skipped += int(suite.get('skipped', suite.get('skip', 0)) or 0)
    return tests, failed, skipped


def main():
    results = Path(sys.argv[1])
    totals = [0, 0, 0]
    broken = False
    for path in sorted(results.glob('*.xml')):
        try:
            tests, failed, skipped = count(path)
        except (ElementTree.ParseError, ValueError) as error:
            print('%s: unreadable (%s)' % (path.name, error))
            broken = True
            continue
        wrapper = path.name.startswith('rostest-')
        if wrapper:
            if failed:
                print('%-45s the rostest itself failed (%d)' % (path.name, failed))
            totals[1] += failed
            continue
        print('%-45s %3d tests, %d failed, %d skipped' % (path.name, tests, failed, skipped))
        if tests == 0:
            print('%-45s ran no test case' % path.name)
            broken = True
        totals = [t + n for t, n in zip(totals, (tests, failed, skipped))]
    tests, failed, skipped = totals
    print('%d passed, %d failed, %d skipped' % (tests - failed - skipped, failed, skipped))
    if tests == 0:
        print('no test ran')
    sys.exit(1 if failed or broken or tests == 0 else 0)


if __name__ == '__main__':
    main()
