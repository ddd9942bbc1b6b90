#!/bin/bash
# Take docs/dashboard.png: the dashboard's overview of a fleet of ten in headless Chromium
# (1280x800), with one robot charging, one low, one critical and one silent (stale).
# Its own master on a free port; every process it starts is ended by its pid.
set -eo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
export PATH="/usr/bin:$PATH"
"$root/tools/build.sh" >/dev/null
source "$root/build/devel/setup.bash"
free_port() { /usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }
port=$(free_port)
web=$(free_port)
export ROS_MASTER_URI=http://127.0.0.1:$port
roslaunch -p "$port" battery_simulator fleet.launch n:=10 > /dev/null 2>&1 & fleet=$!
trap 'kill -INT $dashboard $fleet 2>/dev/null; wait $dashboard $fleet 2>/dev/null' EXIT
until rosservice list 2>/dev/null | grep -q /robot9/battery_simulator/inject_fault; do sleep 0.2; done
# after the fleet's roslaunch has set /run_id: two starting at once race for it
roslaunch battery_simulator dashboard.launch port:="$web" > /dev/null 2>&1 & dashboard=$!
call() { rosservice call "/$1/battery_simulator/$2" "$3" > /dev/null; }
call robot1 set_charging '{data: true}'
call robot1 set_state '{percentage: 46, temperature_c: .nan, state_of_health: .nan}'
call robot4 set_state '{percentage: 14, temperature_c: .nan, state_of_health: .nan}'
call robot7 set_state '{percentage: 3.5, temperature_c: .nan, state_of_health: .nan}'
call robot8 inject_fault '{fault: sensor_dropout, active: true}'
sleep 5   # robot8 goes stale 3 s after its last battery_status
/usr/bin/python3 - "http://127.0.0.1:$web/" "$root/docs/dashboard.png" <<'PY'
import sys
from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.support.ui import WebDriverWait
options = webdriver.ChromeOptions()
for argument in ('--headless=new', '--no-sandbox', '--disable-gpu', '--window-size=1280,800', '--hide-scrollbars'):
    options.add_argument(argument)
driver = webdriver.Chrome(options=options, service=Service('/usr/bin/chromedriver'))
try:
    driver.get(sys.argv[1])
    WebDriverWait(driver, 30).until(lambda d: d.execute_script(
        "return document.querySelectorAll('[data-battery].stale').length") == 1)
    driver.save_screenshot(sys.argv[2])
finally:
    driver.quit()
PY
echo "docs/dashboard.png written"
