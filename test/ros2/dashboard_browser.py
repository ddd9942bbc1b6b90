#!/usr/bin/python3
"""What a person sees on the dashboard's overview, read in headless Chromium (Debian's python3-selenium,
on /usr/bin/python3: the ROS 2 venv has no selenium): prints one JSON object
{"topics": [...], "fields": {topic: {field: text}}, "classes": {topic: [...]}, "errors": [...]}.

    /usr/bin/python3 test/ros2/dashboard_browser.py URL COUNT TIMEOUT_S
waits (bounded) until COUNT batteries show a level, then reads them."""
import json
import os
import shutil
import sys
import tempfile

from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.support.ui import WebDriverWait

FIELDS = ('percentage', 'status', 'voltage', 'current', 'temperature', 'time_remaining')
READ = '''
const fields = arguments[0];
const cards = [...document.querySelectorAll('[data-battery]')];
return cards.map((card) => [card.getAttribute('data-battery'), [...card.classList],
  Object.fromEntries(fields.map((f) => [f, (card.querySelector('[data-field="' + f + '"]') || {}).textContent]))]);
'''


def main():
    url, count, timeout_s = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
    options = webdriver.ChromeOptions()
    for argument in ('--headless=new', '--no-sandbox', '--disable-gpu', '--window-size=1280,900'):
        options.add_argument(argument)
    options.set_capability('goog:loggingPrefs', {'browser': 'ALL'})
    # Chromium's own temporary directories in one of ours, removed after (it leaves one in TMPDIR at every quit)
    temporary = tempfile.mkdtemp(prefix='dashboard_browser_')
    driver = webdriver.Chrome(options=options, service=Service('/usr/bin/chromedriver',
                                                               env=dict(os.environ, TMPDIR=temporary)))
    try:
        driver.get(url)

        def shown(d):
            cards = d.execute_script(READ, FIELDS)
            return cards if len(cards) >= count and all(c[2]['percentage'] not in (None, '-') for c in cards) \
                else False
        cards = WebDriverWait(driver, timeout_s, poll_frequency=0.1).until(shown, 'a level on %d cards' % count)
        errors = [entry['message'] for entry in driver.get_log('browser') if entry['level'] == 'SEVERE']
        print(json.dumps({'topics': [c[0] for c in cards], 'classes': {c[0]: c[1] for c in cards},
                          'fields': {c[0]: c[2] for c in cards}, 'errors': errors}))
    finally:
        driver.quit()
        shutil.rmtree(temporary, ignore_errors=True)


if __name__ == '__main__':
    main()
