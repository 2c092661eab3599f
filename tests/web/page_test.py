#!/usr/bin/python3
"""Browser test of the page plexusd serves at --http (tools/web/page/, docs/WEB.md).

Drives headless Chromium (Debian's chromium + chromium-driver + python3-selenium; run with
/usr/bin/python3) against a daemon running the gaze demo: /demo/face/out and /demo/object/out
both connected into /gaze/in with recv.priority. It relies only on the page's documented hooks
(top of tools/web/page/app.js).

Two steps a harness can call:

    driver = page_test.open_browser()
    winner = page_test.check_page(url, driver)        # both connections listed, plot fed, no error
    ... stop the winner's detector ...
    page_test.wait_winner(driver, not_equal=winner, timeout=10)
    page_test.finish(driver, "artefacts/web-page.png")   # screenshot, console check, quit

`check_page(url)` without a driver opens one (then `page_test.DRIVER`). Every step fails on any
SEVERE browser console entry (a JS error, a failed request). Waits poll with deadlines.

As a program:
    page_test.py URL [ARTEFACTS_DIR] [--screenshot PATH] [--port /gaze/in]
                 [--expect-connections /demo/face/out,/demo/object/out]
                 [--wait-winner-change SECONDS]
Exit status 0 when every check passed; the screenshot is saved either way.
"""
import argparse
import json
import os
import signal
import sys
import time

from selenium import webdriver
from selenium.common.exceptions import JavascriptException, TimeoutException, WebDriverException
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import WebDriverWait

GAZE_PORT = '/gaze/in'
GAZE_CONNECTIONS = ('/demo/face/out', '/demo/object/out')
CHROMIUM = os.environ.get('PLEXUS_CHROMIUM', '/usr/bin/chromium')
CHROMEDRIVER = os.environ.get('PLEXUS_CHROMEDRIVER', '/usr/bin/chromedriver')

DRIVER = None


class PageError(AssertionError):
    pass


def open_browser(width=1280, height=800):
    """Headless Chromium at the size a person would use, keeping every console entry."""
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ('--headless=new', '--no-sandbox', '--disable-dev-shm-usage', '--disable-gpu',
                f'--window-size={width},{height}', '--hide-scrollbars', '--no-first-run',
                '--disable-extensions', '--disable-background-networking'):
        options.add_argument(arg)
    options.set_capability('goog:loggingPrefs', {'browser': 'ALL'})
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    # --window-size is the window, toolbars included: make the page itself width x height
    driver.execute_cdp_cmd('Emulation.setDeviceMetricsOverride',
                           {'width': width, 'height': height, 'deviceScaleFactor': 1, 'mobile': False})
    driver.set_page_load_timeout(30)
    driver.plexus_console = []          # every console entry seen so far (get_log drains them)
    return driver


def console(driver):
    """All browser console entries so far; fails on any SEVERE one."""
    try:
        driver.plexus_console.extend(driver.get_log('browser'))
    except WebDriverException:
        pass
    severe = [e for e in driver.plexus_console if e.get('level') == 'SEVERE']
    if severe:
        raise PageError('browser console errors:\n' + '\n'.join(
            f"  {e.get('source', '')}: {e.get('message', '')}" for e in severe))
    return driver.plexus_console


def wait(driver, what, fn, timeout, seen=None):
    """Polls fn(driver) until it returns something truthy, at most timeout seconds. On a timeout
    the message has seen['last'] (what fn saw last) when fn keeps it there."""
    last = {}

    def probe(d):
        try:
            value = fn(d)
        except JavascriptException as e:
            last['error'] = str(e).splitlines()[0]
            return False
        last['value'] = value
        return value

    try:
        return WebDriverWait(driver, timeout, poll_frequency=0.1).until(probe)
    except TimeoutException:
        if seen and 'last' in seen:
            detail = f" (saw: {seen['last']!r})"
        elif 'error' in last:
            detail = f" (last: {last['error']})"
        else:
            detail = f" (last: {last.get('value')!r})"
        raise PageError(f'timed out after {timeout} s waiting for {what}{detail}') from None


def winner_text(driver):
    return driver.find_element(By.CSS_SELECTOR, '[data-testid="winner"]').text.strip()


def check_page(url, driver=None, port=GAZE_PORT, connections=GAZE_CONNECTIONS,
               min_points=20, timeout=20):
    """Opens the page at url and checks, as a person would see it: `port` selected (the first
    arbitrated port is by default), its connections listed, the plot fed by the 20 Hz stream in
    the last seconds for every connection, the stream connected, a winner shown, no console
    error. Returns the winner shown ("none" or a source port)."""
    global DRIVER
    if driver is None:
        if DRIVER is None:
            DRIVER = open_browser()
        driver = DRIVER
    driver.get(url)
    wait(driver, 'the page script (window.plexusPage)',
         lambda d: d.execute_script('return !!(window.plexusPage && window.plexusPage.selectedPort)'), timeout)
    selected = driver.execute_script('return window.plexusPage.selectedPort')
    if selected != port:
        driver.execute_script('window.plexusPage.select(arguments[0])', port)
        wait(driver, f'{port} selected',
             lambda d: d.execute_script('return window.plexusPage.selectedPort') == port, timeout)

    seen = {}

    def listed(d):
        found = seen['last'] = d.execute_script(
            'return [...document.querySelectorAll(\'[data-testid="connection-list"] [data-source]\')]'
            '.map(e => e.getAttribute("data-source"))')
        return found if all(c in found for c in connections) else False
    wait(driver, f'connections {", ".join(connections)} listed for {port}', listed, timeout, seen)

    def plotted(d):
        points = seen['last'] = d.execute_script('return window.plexusPage.plotPoints()') or {}
        return points if all(points.get(c, 0) >= min_points for c in connections) else False
    points = wait(driver, f'at least {min_points} plot points in the last 10 s per connection', plotted, timeout, seen)
    if not driver.find_elements(By.CSS_SELECTOR, '[data-testid="plot"] canvas'):
        raise PageError('the plot has no canvas')
    if not driver.find_elements(By.CSS_SELECTOR, '#graph canvas'):
        raise PageError('the graph has no canvas')

    def drawn(d):
        g = seen['last'] = d.execute_script('return window.plexusPage.graph()') or {}
        return all(p in g.get('ports', []) for p in (port, *connections)) and \
            all(f'{c}->{port}' in g.get('edges', []) for c in connections)
    wait(driver, f'the graph drawing {port} and its connections', drawn, timeout, seen)
    wait(driver, 'the stream connected (no "disconnected" badge)',
         lambda d: not d.find_element(By.CSS_SELECTOR, '[data-testid="disconnected"]').is_displayed(), timeout)
    winner = wait(driver, 'a winner shown', lambda d: winner_text(d), timeout)
    if winner != 'none' and winner not in connections:
        raise PageError(f'winner shown is {winner!r}, not one of {connections}')
    console(driver)
    print(f'page: {port} selected, connections listed, plot points {json.dumps(points)}, winner {winner}')
    return winner


def wait_winner(driver, not_equal, timeout=15):
    """Waits until the winner shown is no longer not_equal; returns the new one."""
    winner = wait(driver, f'the winner shown to change from {not_equal}',
                  lambda d: (lambda w: w if w and w != not_equal else False)(winner_text(d)), timeout)
    console(driver)
    print(f'page: winner changed from {not_equal} to {winner}')
    return winner


def wait_winner_is(driver, source, timeout=30):
    """Waits until the winner shown is `source`."""
    wait(driver, f'{source} to be shown as the winner', lambda d: winner_text(d) == source, timeout)
    console(driver)
    print(f'page: winner is {source}')


def stop_winner(driver, source, pid, timeout=30):
    """Waits until `source` wins, stops its writer (process `pid`, SIGTERM), and waits until the
    page shows another winner (or none): what a person sees when a detector stops."""
    wait_winner_is(driver, source, timeout)
    os.kill(pid, signal.SIGTERM)
    print(f'page: stopped {source} (pid {pid})')
    return wait_winner(driver, not_equal=source, timeout=timeout)


def screenshot(driver, path):
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    driver.save_screenshot(path)
    print(f'page: screenshot {path}')


def finish(driver, screenshot_path=None):
    """Screenshot (if asked), a last console check, and the browser closed."""
    try:
        if screenshot_path:
            screenshot(driver, screenshot_path)
        console(driver)
    finally:
        driver.quit()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('url', help="plexusd's --http address, e.g. http://127.0.0.1:8080/")
    ap.add_argument('artefacts', nargs='?', help='directory for the screenshot (web-page.png)')
    ap.add_argument('--screenshot', help='screenshot path (default ARTEFACTS/web-page.png)')
    ap.add_argument('--port', default=GAZE_PORT)
    ap.add_argument('--expect-connections', default=','.join(GAZE_CONNECTIONS))
    ap.add_argument('--wait-winner-change', type=float, metavar='SECONDS',
                    help='also wait (at most SECONDS) for the winner shown to change')
    ap.add_argument('--stop-winner', metavar='SOURCE=PID',
                    help='wait until SOURCE wins, stop process PID (its writer), wait for the winner to change')
    ap.add_argument('--timeout', type=float, default=20)
    args = ap.parse_args(argv)
    shot = args.screenshot or (os.path.join(args.artefacts, 'web-page.png') if args.artefacts else None)
    connections = tuple(c for c in args.expect_connections.split(',') if c)
    driver = open_browser()
    try:
        winner = check_page(args.url, driver, port=args.port, connections=connections, timeout=args.timeout)
        if args.wait_winner_change:
            wait_winner(driver, not_equal=winner, timeout=args.wait_winner_change)
        if args.stop_winner:
            source, pid = args.stop_winner.rsplit('=', 1)
            stop_winner(driver, source, int(pid), timeout=max(args.timeout, 30))
    except PageError as e:
        print(f'FAIL: {e}', file=sys.stderr)
        try:
            for entry in driver.plexus_console:
                print(f"  console {entry.get('level')}: {entry.get('message')}", file=sys.stderr)
        except Exception:
            pass
        try:
            if shot:
                screenshot(driver, shot)
        finally:
            driver.quit()
        return 1
    finish(driver, shot)
    print('PASS')
    return 0


if __name__ == '__main__':
    sys.exit(main())
