"""The teaching station in a real headless Chromium, on the simulator.

Every test serves a real session (simulated rover, road library, recorder) on a free loopback
port and drives it the way a person would: through the page's buttons and keys.
"""

from __future__ import annotations

import json
import time
import urllib.error
import urllib.request
from typing import Any

import pytest
from lfd_test_support import wait_until
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect

from lfd_track.core.commands import Command
from lfd_track.dataset import load_demonstration
from lfd_track.web.contract import STATUS_FIELDS

pytestmark = pytest.mark.browser

WAIT_S = 15.0  # failure guard only: every wait returns as soon as its condition holds
STRAIGHT_TRACK = """\
name = "straight"
description = "a 6 m straight strip: forward is always right, so the policy learns it fast"
closed = false
width_m = 0.30
vertices = [[0.0, 0.0], [6.0, 0.0]]
"""


def page_value(page: Any, expression: str) -> Any:
    return page.evaluate(f"() => {expression}")


def open_page(browser: Any, url: str, **context: Any) -> Any:
    """A page on ``url`` once it shows frames (as controller, if it is the first page)."""
    page = browser.new_context(**context).new_page()
    page.goto(url)
    wait_until(lambda: page_value(page, "window.lfd && window.lfd.frames > 0"), "the first frame")
    return page


def as_controller(browser: Any, url: str) -> Any:
    page = open_page(browser, url)
    wait_until(lambda: page_value(page, "window.lfd.role") == "controller", "control")
    return page


def settled(session: Any, cases: int, count: str = "cases") -> dict[str, Any]:
    """The status once ``cases`` cases (or, with ``count="steps"``, commands) are recorded and no
    command is left to run; one more than that fails at once, showing the status."""
    try:
        status = wait_until(
            lambda: (
                (s := session.status())[count] >= cases
                and not session.commander.pending
                and not s["driving"]  # the step is over, every observer has seen it
                and s
            ),
            f"{cases} {count}",
        )
    except AssertionError as exc:
        raise AssertionError(f"{exc}; status {session.status()}") from None
    assert status[count] == cases, status
    return status


def tap(page: Any, command: str) -> None:
    """A quick tap on the page's ``command`` button: its press and its release leave the page in
    one task, as the raw-socket tests send them. ``page.click`` sends the two as separate browser
    inputs; on a loaded machine they can reach the page a control period apart, and the station
    then rightly repeats the held command (tests that use real input give it a longer period)."""
    page.locator(f'[data-command="{command}"]').evaluate(
        """button => { for (const type of ["pointerdown", "pointerup"])
            button.dispatchEvent(new PointerEvent(type, {bubbles: true, cancelable: true})); }"""
    )


def http_get(url: str) -> tuple[int, bytes]:
    opener = urllib.request.build_opener(urllib.request.ProxyHandler({}))  # loopback, no proxy
    try:
        with opener.open(url, timeout=10) as response:
            return response.status, response.read()
    except urllib.error.HTTPError as exc:
        return exc.code, exc.read()


def test_three_forward_clicks_record_three_cases(browser, open_station) -> None:
    # Real clicks and keys: a period of 0.5 s keeps a click from counting as a held button even
    # when its mouse-up reaches the page late.
    station = open_station("--period", "0.5")
    page = as_controller(browser, station.url)
    assert page.locator("#camera").get_attribute("src").startswith("blob:")
    for _ in range(3):
        page.click('[data-command="forward"]')
    status = settled(station.session, 3)
    assert status["counts"] == {"forward": 3, "left": 0, "right": 0}
    assert status["mode"] == "human" and status["steps"] == 3
    demo = load_demonstration(station.out)  # readable while the station still records
    assert demo.commands.tolist() == [Command.FORWARD] * 3
    # Arrow keys drive too; the page shows the counts.
    page.keyboard.press("ArrowLeft")
    settled(station.session, 4)
    wait_until(lambda: page.locator("#counts").inner_text() == "3 / 1 / 0", "the page's counts")
    # The pinned status API.
    code, body = http_get(station.url + "api/status")
    status = json.loads(body)
    assert code == 200 and set(STATUS_FIELDS) <= set(status)
    assert status["cases"] == 4 and status["mode"] == "human"
    assert status["learning_paused"] is False and status["library_models"] >= 1
    assert status["generation"] is None and status["agreement"] is None  # not --online
    # Drawing the road values for the page never counted as a selection: the first road type
    # was compared once per command (40 regions), although the page showed every frame.
    library = station.session.loop.perception.library
    assert library.type_statistics()[0][1] == 40 * 4


def test_library_only_commands_build_the_library_without_cases(browser, open_station) -> None:
    station = open_station("--library-only", "2")
    page = as_controller(browser, station.url)
    for _ in range(3):
        tap(page, "forward")
    status = settled(station.session, 3, count="steps")
    assert status["cases"] == 1 and status["library_models"] == 3


def test_a_phone_drives_by_touch(browser, open_station) -> None:
    station = open_station("--period", "0.5")  # real touches, as in the test of clicks
    page = open_page(
        browser, station.url, viewport={"width": 390, "height": 844}, has_touch=True, is_mobile=True
    )
    wait_until(lambda: page_value(page, "window.lfd.role") == "controller", "control")
    page.tap('[data-command="right"]')
    page.tap('[data-command="forward"]')
    status = settled(station.session, 2)
    assert status["counts"] == {"forward": 1, "left": 0, "right": 1}


def test_the_live_view_runs_at_5_frames_per_second_or_more(browser, open_station) -> None:
    station = open_station()
    page = open_page(browser, station.url)
    first = page_value(page, "[window.lfd.frames, performance.now()]")
    wait_until(lambda: page_value(page, f"performance.now() - {first[1]} > 2000"), "2 s of stream")
    last = page_value(page, "[window.lfd.frames, performance.now()]")
    rate = (last[0] - first[0]) / ((last[1] - first[1]) / 1000.0)
    assert rate >= 5.0, f"{rate:.1f} frames/s"
    assert page_value(page, "!document.querySelector('#topdown').hidden")  # the sim's map


def test_pausing_learning_keeps_the_library_from_growing(browser, open_station) -> None:
    station = open_station()
    page = as_controller(browser, station.url)
    tap(page, "forward")
    models = settled(station.session, 1)["library_models"]
    assert models == 1
    toggle = page.locator('[data-action="pause-learning"]')
    toggle.click()
    wait_until(lambda: station.session.status()["learning_paused"], "learning paused")
    wait_until(lambda: toggle.get_attribute("aria-pressed") == "true", "the switch to show it")
    for _ in range(3):
        tap(page, "forward")
    status = settled(station.session, 4)
    assert status["library_models"] == models
    toggle.click()
    wait_until(lambda: not station.session.status()["learning_paused"], "learning resumed")
    tap(page, "forward")
    assert settled(station.session, 5)["library_models"] > models  # learning again
    demo = load_demonstration(station.out)
    assert demo.learned.tolist() == [True, False, False, False, True]


def test_the_rule_pauses_learning_while_the_safe_box_is_off_the_felt(
    browser, open_station, tmp_path
) -> None:
    track = tmp_path / "straight.toml"
    track.write_text(STRAIGHT_TRACK)
    station = open_station("--track", str(track))
    page = as_controller(browser, station.url)
    for given in range(1, 5):  # four pivots: about 90 degrees, the safe box sees carpet
        tap(page, "left")
        settled(station.session, given)
    status = station.session.status()
    assert status["learning_auto_paused"] and not status["learning_paused"]
    wait_until(lambda: "by the rule" in page.locator("#learning").inner_text(), "the page's note")
    models = status["library_models"]
    tap(page, "left")
    assert settled(station.session, 5)["library_models"] == models
    assert not load_demonstration(station.out).learned[-1]


def test_a_second_page_watches_and_cannot_drive(browser, open_station) -> None:
    station = open_station()
    controller = as_controller(browser, station.url)
    watcher = open_page(browser, station.url)
    wait_until(lambda: page_value(watcher, "window.lfd.role") == "watcher", "the watcher role")
    assert watcher.locator('[data-command="forward"]').is_disabled()
    watcher.evaluate("() => window.lfd")  # the page is live
    # Even a hand-made command from the watcher's socket is refused.
    with connect(station.url.replace("http", "ws") + "ws", proxy=None, max_queue=None) as ws:
        ws.send(json.dumps({"type": "press", "command": "forward"}))
        errors = []
        while not errors:
            message = ws.recv(timeout=WAIT_S)
            if isinstance(message, str) and json.loads(message)["type"] == "error":
                errors.append(json.loads(message)["message"])
    assert "another page controls the robot" in errors[0]
    assert station.session.status()["steps"] == 0
    # ... but any page may stop the robot.
    controller.locator('[data-command="forward"]').hover()
    controller.mouse.down()  # held on the controlling page
    wait_until(lambda: station.session.status()["steps"] >= 1, "the held command")
    assert watcher.locator('[data-action="stop"]').is_enabled()
    watcher.click('[data-action="stop"]')
    wait_until(lambda: station.session.status()["stopped_reason"], "the watcher's stop")
    assert not station.session.commander.pending
    controller.mouse.up()
    controller.close()  # the controlling page leaves: control is free for the watcher
    wait_until(lambda: watcher.locator("#claim").is_visible(), "the take-control button")
    watcher.click("#claim")
    wait_until(lambda: page_value(watcher, "window.lfd.role") == "controller", "control")
    watcher.click('[data-command="right"]')
    wait_until(lambda: station.session.status()["counts"]["right"] == 1, "the watcher's command")


def test_the_robot_stops_when_the_page_goes_silent(open_station) -> None:
    """A page that holds forward and then sends nothing (phone asleep) stops the robot in ~1 s."""
    station = open_station()
    with connect(station.url.replace("http", "ws") + "ws", proxy=None, max_queue=None) as ws:
        ws.send(json.dumps({"type": "press", "command": "forward"}))  # held, never released
        wait_until(lambda: station.session.status()["steps"] >= 2, "the held command to run")
        silent_since = time.monotonic()
        status = wait_until(
            lambda: (s := station.session.status())["stopped_reason"] and s, "the lease to end"
        )
        stopped_after = time.monotonic() - silent_since
        assert "heartbeat" in status["stopped_reason"] and status["mode"] == "human"
        steps = status["steps"]
        # Still connected, still silent: nothing moves any more.
        assert not station.session.commander.pending
        assert stopped_after < 1.5
        ws.send(json.dumps({"type": "heartbeat"}))  # a page that wakes up may drive again
        ws.send(json.dumps({"type": "press", "command": "left"}))
        ws.send(json.dumps({"type": "release"}))
        wait_until(lambda: station.session.status()["steps"] == steps + 1, "one more command")
        # Silent again: once its lease has run out, another page may take control.
        wait_until(lambda: not station.session.status()["lease_alive"], "the lease to lapse")
        with connect(station.url.replace("http", "ws") + "ws", proxy=None, max_queue=None) as other:
            other.send(json.dumps({"type": "claim"}))
            wait_until(lambda: _role(other) == "controller", "the other page to take control")
            ws.send(json.dumps({"type": "press", "command": "right"}))  # the sleeper woke up
            while True:
                message = ws.recv(timeout=WAIT_S)
                if isinstance(message, str) and json.loads(message)["type"] == "error":
                    break
            assert "another page controls the robot" in json.loads(message)["message"]
        assert station.session.status()["counts"]["right"] == 0


def _role(ws: Any) -> str | None:
    """The role in the next status message on a raw WebSocket."""
    while True:
        message = ws.recv(timeout=WAIT_S)
        if isinstance(message, str) and json.loads(message)["type"] == "status":
            return json.loads(message)["role"]


def test_stop_button_and_space_bar_stop_a_held_command(browser, open_station) -> None:
    station = open_station()
    page = as_controller(browser, station.url)
    button = page.locator('[data-command="forward"]')
    button.hover()
    page.mouse.down()  # held: the command repeats each control period
    wait_until(lambda: station.session.status()["steps"] >= 2, "the held command to repeat")
    page.keyboard.press(" ")
    status = wait_until(lambda: (s := station.session.status())["stopped_reason"] and s, "stop")
    assert not station.session.commander.pending and status["mode"] == "human"
    page.mouse.up()


def test_a_token_is_required_on_every_request_and_the_websocket(browser, open_station) -> None:
    token = "test-token-123"
    station = open_station(token=token)
    base = station.url.split("?")[0]
    for path in ("", "api/status", "static/app.js", "static/style.css"):
        code, body = http_get(base + path)
        assert code == 403 and b"token" in body, path
        assert http_get(base + path + "?token=wrong")[0] == 403
        assert http_get(base + path + f"?token={token}")[0] == 200
    for url in (base.replace("http", "ws") + "ws", base.replace("http", "ws") + "ws?token=x"):
        with pytest.raises(InvalidStatus) as refused:
            with connect(url, proxy=None, max_queue=None) as ws:
                ws.send(json.dumps({"type": "press", "command": "forward"}))
        assert refused.value.response.status_code == 403
    # A page of another site cannot drive the robot from the user's browser either.
    with pytest.raises(InvalidStatus) as refused:
        with connect(
            base.replace("http", "ws") + f"ws?token={token}",
            origin="http://elsewhere.example",
            proxy=None,
            max_queue=None,
        ):
            pass
    assert refused.value.response.status_code == 403
    assert station.session.status()["steps"] == 0  # no motion
    page = as_controller(browser, station.url)  # the printed URL carries the token
    tap(page, "forward")
    assert settled(station.session, 1)["steps"] == 1


def test_online_takeover_then_a_human_command_is_a_correction(
    browser, open_station, tmp_path
) -> None:
    track = tmp_path / "straight.toml"
    track.write_text(STRAIGHT_TRACK)
    station = open_station(
        "--online", "--track", str(track), "--takeover-window", "3",
        "--takeover-threshold", "1", "--generations-per-case", "5", "--population", "20",
    )  # fmt: skip
    session = station.session
    page = as_controller(browser, station.url)
    takeover = page.locator('[data-action="takeover"]')
    assert takeover.is_visible() and takeover.is_disabled()  # no policy before the first case
    for given in range(1, 16):  # demonstrate until the station offers the takeover
        tap(page, "forward")
        status = settled(session, given)
        if status["takeover_offered"]:
            break
    assert status["takeover_offered"], status
    assert status["agreement"] == 1.0 and status["generation"] == 5 * given
    assert status["best_fitness"] is not None and status["mode"] == "human"
    wait_until(lambda: "offer" in (takeover.get_attribute("class") or ""), "the offer on the page")
    takeover.click()
    wait_until(lambda: session.status()["mode"] == "autonomous", "the policy to drive")
    steps = session.status()["steps"]
    wait_until(lambda: session.status()["steps"] >= steps + 2, "the policy's own commands")
    assert session.status()["cases"] == given  # the policy's commands are not teaching cases
    wait_until(lambda: page.locator("#mode").inner_text() == "policy drives", "the page's badge")
    tap(page, "left")  # the human takes control back
    status = wait_until(lambda: (s := session.status())["corrections"] == 1 and s, "the correction")
    assert status["mode"] == "human" and status["cases"] == given + 1
    code, body = http_get(station.url + "api/status")
    assert json.loads(body)["mode"] == "human" and json.loads(body)["corrections"] == 1
    demo = load_demonstration(station.out)
    assert demo.commands.tolist() == [Command.FORWARD] * given + [Command.LEFT]
    assert demo.phases.tolist() == ["drive"] * given + ["correction"]
    assert demo.sources.tolist() == ["demonstration"] * given + ["correction"]


def _teach(station, commands: list[str]) -> dict:
    """Press and release each command over the page's websocket; the status after the last."""
    with connect(station.url.replace("http", "ws") + "ws", proxy=None, max_queue=None) as ws:
        for given, command in enumerate(commands, start=1):
            ws.send(json.dumps({"type": "press", "command": command}))
            ws.send(json.dumps({"type": "release"}))
            status = settled(station.session, given)
    return status


def _teach_online(open_station, memory: list[str], commands: list[str], weights: int):
    """Teach ``commands`` online (population 10) with the ``memory`` flags: the GA has evolved
    networks of ``weights`` weights; the recording, once the session is closed."""
    station = open_station("--online", *memory, "--population", "10")
    session = station.session
    status = _teach(station, commands)
    assert status["generation"] is not None and status["generation"] > 0
    assert session.learner.state.population.shape == (10, weights)
    session.close()
    return load_demonstration(station.out)


def test_online_teaching_with_memory_learns_from_the_wider_input(open_station) -> None:
    """``--online --memory last_bend``: the cases carry the memory and the GA evolves networks
    that read it (41 inputs, 220 weights)."""
    commands = ["right", "right", "forward", "forward"]
    demo = _teach_online(open_station, ["--memory", "last_bend"], commands, 220)
    assert demo.memory[:, 0].tolist() == [0.5, 0.5, 0.0, 0.0]


def test_online_teaching_with_the_fresh_felt_map_learns_from_its_three_inputs(open_station) -> None:
    """``--online --memory fresh_felt --blank-bearing last`` (round 10's chosen inputs): every
    case carries the map's bearing, amount and distance, and the GA evolves networks that read
    them (43 inputs, 230 weights)."""
    from lfd_track.policy.memory import FreshFeltConfig

    memory = ["--memory", "fresh_felt", "--blank-bearing", "last"]
    demo = _teach_online(open_station, memory, ["forward", "forward", "left", "forward"], 230)
    assert demo.metadata["memory"] == FreshFeltConfig(blank_bearing="last").to_dict()
    assert demo.memory.shape == (4, 3)
    assert ((demo.memory >= 0) & (demo.memory <= 1)).all()
    assert demo.memory[:, 1].max() > 0  # the felt ahead of the start is on the map


def test_online_teaching_of_the_goals_chosen_policy_kind_reads_the_map_alone(open_station) -> None:
    """``--online --features none`` with the map (bearing over +-30 deg) and a GA with biases:
    the policy the goal chose (a 3-5-3 network on the map, 38 weights with biases) is what the
    GA evolves while the person teaches, and the recording keeps the map's settings."""
    from lfd_track.policy.memory import FreshFeltConfig

    flags = [
        "--memory", "fresh_felt", "--blank-bearing", "last", "--bearing-range", "30",
        "--strip-link", "0.15", "--blank-reach", "1.0", "--blank-distance", "reach",
        "--visited-fade", "0.3", "--strip-picture-links", "--features", "none", "--ga-bias",
        "--mutation-delta", "0.5",
    ]  # fmt: skip
    demo = _teach_online(open_station, flags, ["forward", "forward", "left", "forward"], 38)
    expected = FreshFeltConfig(
        blank_bearing="last",
        bearing_range_deg=30.0,
        strip_link_m=0.15,
        blank_reach_m=1.0,
        blank_distance="reach",
        visited_fade_m=0.3,
        strip_picture_links=True,
    )
    assert demo.metadata["memory"] == expected.to_dict()
    assert demo.policy_inputs("none").shape == (4, 3)
