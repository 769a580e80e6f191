#!/usr/bin/env python3
"""The dashboard in a real browser (headless Chromium driven by Selenium, Debian's chromium,
chromium-driver and python3-selenium) against a real local space (space.py): it logs in, finds
every service of the space, sees the robot's marker move while the square-path task runs, the
square's plot fill and the markers the camera riding on the robot recognises lit on the map, activates and deactivates a component and sees its state change, calls an
operation from the generated form and reads the reply and a typed error, and a viewer's login
cannot act. Screenshots are written to OUT_DIR.

    browser_test.py BUILD_DIR SOURCE_DIR OUT_DIR

Against spaces already running (the compose spaces, say), a generic scenario: log in, every space
of the graph drawn with services (and every service --expect-services names), a robot's marker
moving (after a moveTo called from the form; with --robot watch, driven around the square and
back by someone else, who may start once --ready-file is written), a component activated and deactivated
where one can be (--must-activate: one must be), an echo called from the form (another space's
when there is one):

    browser_test.py --url http://localhost:8765/ --credential-file compose/config/kr-operator.token \
        --out DIR [--spaces kr,jp] [--expect-services FILE] [--robot move|watch|none] \
        [--ready-file FILE] [--must-activate] [--component PATH]
"""
import contextlib
import json
import math
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


@contextlib.contextmanager
def browser_session(out, failure_shot):
    """A browser() and its screenshot function, shot(name) writing OUT/<name>.png. On leaving,
    the page must have logged no SEVERE error; on any failure the screenshot <failure_shot> and
    the browser's log are taken first; the browser is closed in every case."""
    driver = browser()
    shot = lambda name: driver.save_screenshot(os.path.join(out, name + ".png"))  # noqa: E731
    try:
        yield driver, shot
        severe = [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]
        assert not severe, "the page logged errors: %s" % severe
    except BaseException:
        shot(failure_shot)
        print("browser log:", driver.get_log("browser"))
        raise
    finally:
        driver.quit()


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
    with browser_session(out, "dashboard-failure") as (driver, shot):
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


def remote_scenario(url, credential, out, spaces, expected=(), robot_mode="move", ready_file=None,
                    must_activate=False, component=None):
    with browser_session(out, "remote-failure") as (driver, shot):
        js = driver.execute_script
        t0 = time.monotonic()
        log_in(driver, url, credential)
        until("role operator", lambda: driver.find_element(By.ID, "role").text == "operator")
        drawn = until("every space drawn: %s" % spaces, lambda: (lambda names: names if set(spaces) <= set(names) else None)(
            js('return [...document.querySelectorAll("#spaces g[data-space]")].map((g) => g.dataset.space);')), 60)
        for space in drawn:
            until("services of %s listed" % space, lambda: js(
                'return [...document.querySelectorAll("#services tr[data-service]")]'
                '.some((r) => r.dataset.service.startsWith(arguments[0] + "/"));', space), 60)
        if expected:
            def missing():
                rows = set(js('return [...document.querySelectorAll("#services tr[data-service]")].map((r) => r.dataset.service);'))
                return [name for name in expected if name not in rows]
            try:
                until("every expected service listed", lambda: not missing(), 60)
            except AssertionError:
                raise AssertionError("services not listed: %s" % missing())
        robot = until("a robot on the map", lambda: js(
            'const g = document.querySelector("g.robot"); return g ? [g.dataset.robot, +g.dataset.x, +g.dataset.y] : null;'), 60)
        shot("remote-overview")
        position = lambda: js('const g = document.querySelector(\'g.robot[data-robot="\' + arguments[0] + \'"]\');'
                              'return g ? [+g.dataset.x, +g.dataset.y] : null;', robot[0])
        local = driver.find_element(By.ID, "space-name").text
        operations = js('return [...document.querySelectorAll("#operation option")].map((o) => o.value);')
        print("browser: %s logged in, %d services, %d operations, %s on the map after %.1f s" % (
            url, js('return document.querySelectorAll("#services tr[data-service]").length;'), len(operations),
            robot[0], time.monotonic() - t0), flush=True)
        if ready_file:  # whoever runs the robot may start now: the marker is watched from here on
            open(ready_file, "w").write("ready\n")
        if robot_mode == "watch":
            # Something else drives the robot (the square-path task): the marker must move and cover
            # the square's extent; positions are sampled as fast as the page redraws.
            seen = {"xs": [robot[1]], "ys": [robot[2]], "samples": 0, "shot": False}
            def covered():
                p = position()
                if p:
                    seen["xs"].append(p[0])
                    seen["ys"].append(p[1])
                    seen["samples"] += 1
                    if not seen["shot"] and math.hypot(p[0] - robot[1], p[1] - robot[2]) > 0.5:
                        seen["shot"] = True
                        shot("remote-robot-moving")
                dx, dy = max(seen["xs"]) - min(seen["xs"]), max(seen["ys"]) - min(seen["ys"])
                # the square's extent covered, and the marker back where it was first seen
                return dx >= 3.0 and dy >= 1.5 and p and math.hypot(p[0] - robot[1], p[1] - robot[2]) < 0.3
            until("%s's marker driving around the square (x and y ranges >= 3.0 and 1.5 m of its 3.5 x 2 m, "
                  "then back within 0.3 m of (%.2f, %.2f))" % (robot[0], robot[1], robot[2]), covered, 240)
            print("browser: %s's marker covered x %.2f..%.2f, y %.2f..%.2f (%d samples)" % (
                robot[0], min(seen["xs"]), max(seen["xs"]), min(seen["ys"]), max(seen["ys"]), seen["samples"]), flush=True)
            until("a trail drawn", lambda: js('return document.querySelectorAll("#map .trail").length > 0;'), 30)
            shot("remote-robot-square")
        elif robot_mode == "move":
            space, name = robot[0].split("/", 1)
            # The robot's navigation as this space calls it: imported from its space ("jp/robot1.navigation")
            # or its own ("robot1.navigation").
            wanted = ("" if space == local else space + "/") + name + ".navigation/moveTo"
            move = [o for o in operations if o == wanted]
            assert move, "no %s among %d operations" % (wanted, len(operations))
            target_x = 4.0 if robot[1] < 3.0 else 2.0
            reply = call_from_form(driver, move[0], {"x": target_x, "y": 2.0})
            assert not driver.find_element(By.ID, "call-result").get_attribute("class") == "failure", reply
            until("%s's marker moving towards (%s, 2.0)" % (robot[0], target_x), lambda: (lambda p: p and
                  math.hypot(p[0] - robot[1], p[1] - robot[2]) > 0.3)(position()), 60)
            shot("remote-robot-moving")
        activatable = lambda: js('return [...document.querySelectorAll("#components tr[data-component]")]'
                                 '.filter((r) => r.querySelector("td.state").textContent === "Inactive" &&'
                                 ' r.querySelector(\'button[data-transition="activate"]:not([disabled])\'))'
                                 '.map((r) => r.dataset.component);')
        if component:
            inactive = until("%s Inactive with an enabled activate button" % component,
                             lambda: component if component in activatable() else None, 60)
        else:
            inactive = (activatable() or [None])[0]
        assert inactive or not must_activate, "no Inactive component with an enabled activate button in %s" % url
        if inactive:
            # Only the gateway's own space's components can be driven: the row with the buttons.
            row = '#components tr[data-space="%s"][data-component="%s"]' % (local, inactive)
            state = lambda: js('const td = document.querySelector(arguments[0] + " td.state");'
                               'return td ? td.textContent : null;', row)
            assert click(driver, row + ' button[data-transition="activate"]')
            until("%s Active" % inactive, lambda: state() == "Active", 30)
            js('document.querySelector(arguments[0]).scrollIntoView()', row)
            shot("remote-component-active")
            assert click(driver, row + ' button[data-transition="deactivate"]')
            until("%s Inactive again" % inactive, lambda: state() == "Inactive", 30)
        echo = [o for o in operations if o.endswith("/echo")]
        # Rather an echo of another space (imported as "<space>/<service>"): the call crosses the link.
        echo.sort(key=lambda o: o.split("/")[0] not in drawn or o.split("/")[0] == local)
        if echo:
            reply = call_from_form(driver, echo[0], {"text": "hello from the browser"})
            assert json.loads(reply) == {"result": "hello from the browser"}, reply
            driver.execute_script("document.getElementById('call-panel').scrollIntoView()")
            shot("remote-call")
        print("browser: %s: spaces %s, %s %s, %s, %s (%.1f s)" % (url, drawn, robot[0],
              {"watch": "seen driving the square", "move": "moved from the form", "none": "on the map"}[robot_mode],
              "%s activated and deactivated" % inactive if inactive else "no component to activate",
              "%s answered" % echo[0] if echo else "no echo operation", time.monotonic() - t0), flush=True)


def main():
    if "--url" in sys.argv:
        import argparse
        parser = argparse.ArgumentParser()
        parser.add_argument("--url", required=True)
        parser.add_argument("--credential-file", required=True)
        parser.add_argument("--out", required=True)
        parser.add_argument("--spaces", default="")
        parser.add_argument("--expect-services", help="file of '<space>/<service>' lines that must all be listed")
        parser.add_argument("--robot", choices=["move", "watch", "none"], default="move",
                            help="move: moveTo from the form; watch: something else drives it around the square")
        parser.add_argument("--ready-file", help="written once logged in with the robot on the map")
        parser.add_argument("--must-activate", action="store_true", help="fail if no component can be activated")
        parser.add_argument("--component", help="the component to activate and deactivate (default: the first Inactive)")
        args = parser.parse_args()
        os.makedirs(args.out, exist_ok=True)
        credential = open(args.credential_file).read().strip()
        expected = [line.strip() for line in open(args.expect_services) if line.strip()] if args.expect_services else []
        remote_scenario(args.url, credential, args.out, [s for s in args.spaces.split(",") if s], expected,
                        args.robot, args.ready_file, args.must_activate, args.component)
        print("browser: every check passed; screenshots in %s: %s" % (
            args.out, " ".join(sorted(f for f in os.listdir(args.out) if f.endswith(".png")))))
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
