#!/usr/bin/env python3
"""The dashboard in a real browser (headless Chromium driven by Selenium, Debian's chromium,
chromium-driver and python3-selenium) against a real local space (space.py): it logs in, finds
every service of the space, sees the robot's marker move while the square-path task runs, the
square's plot fill and the markers the camera riding on the robot recognises lit on the map, activates and deactivates a component and sees its state change, calls an
operation from the generated form and reads the reply and a typed error, and a viewer's login
cannot act. Screenshots are written to OUT_DIR.

    browser_test.py BUILD_DIR SOURCE_DIR OUT_DIR

Against spaces already running (the compose spaces, say), a generic scenario: log in, every space
of the graph drawn with services, a robot's marker moving after a moveTo called from the form, a
component activated and deactivated where one can be, an echo called from the form:

    browser_test.py --url http://localhost:8765/ --credential-file compose/config/kr.token \
        --out DIR [--spaces kr,jp]
"""
import json
import os
import sys
import time

from selenium import webdriver
from selenium.common.exceptions import StaleElementReferenceException, WebDriverException
from selenium.webdriver.chrome.options import Options
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import Select

from space import Space, TOKEN, VIEWER_TOKEN

RT_PROVIDERS = ["labpc.host_cxt/Camera0.rtc:imagerecognition", "labpc.host_cxt/Diagnostic0.rtc:diagnostic",
                "labpc.host_cxt/camus_diag.rtc:diagnostic"]


def until(what, condition, timeout=30):
    deadline = time.monotonic() + timeout
    last_error = None
    while time.monotonic() < deadline:
        try:
            value = condition()
            if value:
                return value
        except (StaleElementReferenceException, WebDriverException) as e:  # the page redraws as data arrives
            last_error = e
        time.sleep(0.1)
    raise AssertionError("%s did not happen within %s s%s" % (what, timeout, " (%s)" % last_error if last_error else ""))


def browser():
    options = Options()
    for argument in ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                     "--window-size=1500,2300", "--disable-extensions", "--no-first-run"]:
        options.add_argument(argument)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)


# Read in the page in one step: the map and the tables are redrawn as data arrives.
def robot_position(driver):
    found = driver.execute_script(
        'const g = document.querySelector(\'g.robot[data-robot="lab/robot1"]\');'
        'return g ? [g.dataset.x, g.dataset.y] : null;')
    return (float(found[0]), float(found[1])) if found else None


def component_state(driver, name):
    return driver.execute_script(
        'const td = document.querySelector(\'#components tr[data-component="\' + arguments[0] + \'"] td.state\');'
        'return td ? td.textContent : null;', name)


def click(driver, selector):
    """Clicks the element now under `selector` (found and clicked in one step in the page)."""
    return driver.execute_script("const e = document.querySelector(arguments[0]); if (e) e.click(); return !!e;", selector)


def log_in(driver, url, credential):
    driver.get(url)
    until("the login form", lambda: driver.find_element(By.ID, "login-form").is_displayed())
    field = driver.find_element(By.ID, "credential")
    field.clear()
    field.send_keys(credential)
    driver.find_element(By.ID, "login-button").click()
    until("the live badge", lambda: driver.find_element(By.ID, "connection").text == "live")


def call_from_form(driver, operation, fields):
    Select(driver.find_element(By.ID, "operation")).select_by_value(operation)
    for name, value in fields.items():
        field = until("field %s of %s" % (name, operation),
                      lambda: driver.find_element(By.CSS_SELECTOR, '#call-form [data-field="%s"]' % name))
        field.clear()
        field.send_keys(str(value))
    driver.find_element(By.ID, "call-button").click()
    return until("the reply of %s" % operation,
                 lambda: (lambda t: t if t and not t.startswith("calling") else None)(
                     driver.find_element(By.ID, "call-result").text))


def scenario(space, out):
    driver = browser()
    shot = lambda name: driver.save_screenshot(os.path.join(out, name + ".png"))
    try:
        log_in(driver, space.http_url, TOKEN)
        until("role operator", lambda: driver.find_element(By.ID, "role").text == "operator")
        foxglove = driver.find_element(By.ID, "foxglove-url").text
        assert foxglove.startswith(space.gateway_url + "?session="), foxglove

        # Every service of the space: the CAMUS registry's (as the CLI lists it) and the RT providers.
        listed = space.urs("ls", "--json")
        assert listed.returncode == 0, listed.stderr
        camus = [s["name"] for s in json.loads(listed.stdout).get("services", [])]
        assert "diag" in camus and "robot1.navigation" in camus, camus
        expected = ["lab/" + name for name in camus + RT_PROVIDERS]
        def shown():
            rows = set(driver.execute_script(
                'return [...document.querySelectorAll("#services tr[data-service]")].map((r) => r.dataset.service);'))
            return all(name in rows for name in expected)
        until("every service in the table: %s" % expected, shown, 40)
        until("the space drawn", lambda: driver.find_elements(By.CSS_SELECTOR, '#spaces g[data-space="lab"]'))
        until("the RT view", lambda: len(driver.find_elements(By.CSS_SELECTOR, "#rtview g.rtc")) >= 5)
        until("a connection drawn", lambda: driver.find_elements(By.CSS_SELECTOR, "#rtview path.connection"))
        start = until("the robot's marker", lambda: robot_position(driver))
        shot("dashboard-overview")

        # The square path: the marker moves, the plot and its waypoints fill; the camera riding on
        # the robot (opened from the form) recognises wall markers on the way, lit on the map.
        reply = call_from_form(driver, "camera1/openCamera", {"device": 0})
        assert json.loads(reply) == {}, reply
        driver.find_element(By.ID, "run-square").click()
        until("the task started", lambda: "run" in driver.find_element(By.ID, "experiment-status").text)
        until("the robot's marker moving north", lambda: robot_position(driver)[1] > start[1] + 0.5, 60)
        moved = robot_position(driver)
        assert abs(moved[0] - 1.5) < 0.2, "on the first leg x stays 1.5: %s" % (moved,)
        shot("dashboard-square-running")
        def square_done():
            texts = driver.execute_script(
                'return [...document.querySelectorAll("#waypoints tbody td:nth-child(2)")].map((c) => c.textContent);')
            values = [float(t) for t in texts if t]
            return len(values) == 4 and max(values) < 100 and values
        closest = until("every waypoint reached within 100 mm", square_done, 120)
        until("a wall marker recognised by the camera, lit on the map",
              lambda: driver.execute_script('return document.querySelectorAll("#map rect.marker.recognised").length > 0;'), 30)
        print("browser: closest approach to the waypoints (mm):", closest, flush=True)
        shot("dashboard-square-done")

        # Lifecycle: activate and deactivate the camera RTC.
        camera = "labpc.host_cxt/Camera0.rtc"
        until("the camera listed", lambda: component_state(driver, camera) == "Inactive")
        assert click(driver, '#components tr[data-component="%s"] button[data-transition="activate"]' % camera)
        until("the camera Active", lambda: component_state(driver, camera) == "Active", 20)
        until("the RT view shows it Active", lambda: driver.execute_script(
            'const g = document.querySelector(\'#rtview g[data-component="\' + arguments[0] + \'"]\');'
            'return g && g.textContent.includes("Active");', camera))
        shot("dashboard-component-active")
        assert click(driver, '#components tr[data-component="%s"] button[data-transition="deactivate"]' % camera)
        until("the camera Inactive again", lambda: component_state(driver, camera) == "Inactive", 20)

        # A call from the generated form, its reply; and a typed error.
        reply = call_from_form(driver, "diag/echo", {"text": "hello from the browser"})
        assert json.loads(reply) == {"result": "hello from the browser"}, reply
        reply = call_from_form(driver, "labpc.host_cxt/Diagnostic0.rtc:diagnostic/add", {"a": 2, "b": 40})
        assert json.loads(reply) == {"result": 42}, reply
        failure = call_from_form(driver, "diag/fail", {"reason": "shown as typed", "code": 3})
        assert failure.startswith("USER_EXCEPTION URS.Failure") and "shown as typed" in failure, failure
        assert "failure" in driver.find_element(By.ID, "call-result").get_attribute("class")
        call_from_form(driver, "diag/echo", {"text": "hello from the browser"})
        driver.execute_script("document.getElementById('call-panel').scrollIntoView()")
        shot("dashboard-call")

        # The event and context log, filtered.
        Select(driver.find_element(By.ID, "log-kind")).select_by_value("event")
        until("task events in the log", lambda: driver.execute_script(
            'return [...document.querySelectorAll("#log tbody tr")].some((r) => r.textContent.includes("task/square-path"));'))
        driver.execute_script("document.getElementById('log-panel').scrollIntoView()")
        shot("dashboard-log")

        # A viewer sees, and cannot act.
        driver.find_element(By.ID, "logout-button").click()
        until("logged out", lambda: driver.find_element(By.ID, "login-form").is_displayed())
        log_in(driver, space.http_url, VIEWER_TOKEN)
        until("role viewer", lambda: driver.find_element(By.ID, "role").text == "viewer")
        until("the services again", lambda: driver.find_elements(By.CSS_SELECTOR, '#services tr[data-service="lab/diag"]'))
        assert not driver.find_element(By.ID, "call-button").is_enabled(), "a viewer's call button is disabled"
        disabled = until("lifecycle buttons", lambda: driver.execute_script(
            'return [...document.querySelectorAll("#components button.lifecycle")].map((b) => b.disabled);'))
        assert all(disabled), "a viewer's lifecycle buttons are disabled"
        severe = [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]
        assert not severe, "the page logged errors: %s" % severe
    except BaseException:
        shot("dashboard-failure")
        print("browser log:", driver.get_log("browser"))
        raise
    finally:
        driver.quit()


def remote_scenario(url, credential, out, spaces):
    driver = browser()
    shot = lambda name: driver.save_screenshot(os.path.join(out, name + ".png"))
    js = driver.execute_script
    try:
        log_in(driver, url, credential)
        until("role operator", lambda: driver.find_element(By.ID, "role").text == "operator")
        drawn = until("every space drawn: %s" % spaces, lambda: (lambda names: names if set(spaces) <= set(names) else None)(
            js('return [...document.querySelectorAll("#spaces g[data-space]")].map((g) => g.dataset.space);')), 60)
        for space in drawn:
            until("services of %s listed" % space, lambda: js(
                'return [...document.querySelectorAll("#services tr[data-service]")]'
                '.some((r) => r.dataset.service.startsWith(arguments[0] + "/"));', space), 60)
        robot = until("a robot on the map", lambda: js(
            'const g = document.querySelector("g.robot"); return g ? [g.dataset.robot, +g.dataset.x, +g.dataset.y] : null;'), 60)
        shot("remote-overview")
        space, name = robot[0].split("/", 1)
        operations = js('return [...document.querySelectorAll("#operation option")].map((o) => o.value);')
        # The robot's navigation as this space calls it: imported from its space ("jp/robot1.navigation")
        # or its own ("robot1.navigation").
        local = driver.find_element(By.ID, "space-name").text
        wanted = ("" if space == local else space + "/") + name + ".navigation/moveTo"
        move = [o for o in operations if o == wanted]
        assert move, "no %s among %d operations" % (wanted, len(operations))
        target_x = 4.0 if robot[1] < 3.0 else 2.0
        reply = call_from_form(driver, move[0], {"x": target_x, "y": 2.0})
        assert not driver.find_element(By.ID, "call-result").get_attribute("class") == "failure", reply
        until("%s's marker moving towards (%s, 2.0)" % (robot[0], target_x), lambda: js(
            'const g = document.querySelector(\'g.robot[data-robot="\' + arguments[0] + \'"]\');'
            'return g && Math.hypot(+g.dataset.x - arguments[1], +g.dataset.y - arguments[2]) > 0.3;',
            robot[0], robot[1], robot[2]), 60)
        shot("remote-robot-moving")
        inactive = js('const rows = [...document.querySelectorAll("#components tr[data-component]")]'
                      '.filter((r) => r.querySelector("td.state").textContent === "Inactive" &&'
                      ' r.querySelector(\'button[data-transition="activate"]:not([disabled])\'));'
                      'return rows.length ? rows[0].dataset.component : null;')
        if inactive:
            # Only the gateway's own space's components can be driven: the row with the buttons.
            row = '#components tr[data-space="%s"][data-component="%s"]' % (local, inactive)
            state = lambda: js('const td = document.querySelector(arguments[0] + " td.state");'
                               'return td ? td.textContent : null;', row)
            assert click(driver, row + ' button[data-transition="activate"]')
            until("%s Active" % inactive, lambda: state() == "Active", 30)
            shot("remote-component-active")
            assert click(driver, row + ' button[data-transition="deactivate"]')
            until("%s Inactive again" % inactive, lambda: state() == "Inactive", 30)
        echo = [o for o in operations if o.endswith("/echo")]
        if echo:
            reply = call_from_form(driver, echo[0], {"text": "hello from the browser"})
            assert json.loads(reply) == {"result": "hello from the browser"}, reply
            shot("remote-call")
        print("browser: %s: spaces %s, %s moved, %s, %s" % (url, drawn, robot[0],
              "%s activated and deactivated" % inactive if inactive else "no component to activate",
              "%s answered" % echo[0] if echo else "no echo operation"), flush=True)
    except BaseException:
        shot("remote-failure")
        raise
    finally:
        driver.quit()


def main():
    if "--url" in sys.argv:
        import argparse
        parser = argparse.ArgumentParser()
        parser.add_argument("--url", required=True)
        parser.add_argument("--credential-file", required=True)
        parser.add_argument("--out", required=True)
        parser.add_argument("--spaces", default="")
        args = parser.parse_args()
        os.makedirs(args.out, exist_ok=True)
        credential = open(args.credential_file).read().strip()
        remote_scenario(args.url, credential, args.out, [s for s in args.spaces.split(",") if s])
        print("browser: every check passed; screenshots in %s" % args.out)
        return
    build, source, out = sys.argv[1], sys.argv[2], sys.argv[3]
    os.makedirs(out, exist_ok=True)
    for old in os.listdir(out):  # this run's screenshots only
        if old.endswith(".png"):
            os.remove(os.path.join(out, old))
    with Space(build, source, "lab") as space:
        scenario(space, out)
    print("browser: every check passed; screenshots in %s" % out)


if __name__ == "__main__":
    main()
