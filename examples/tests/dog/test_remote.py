"""Remote control: a client in another process drives the dog through the sensor inbox."""

from __future__ import annotations

import socket
import subprocess
import sys
import time

import pytest

from beatlog.model.inbox import Sample, SensorInbox
from beatlog_examples.dog.remote import MAX_SPEED, RemoteCommand, RemoteServer, drive, main


def wait_for(inbox: SensorInbox, count: int, timeout_s: float = 10.0) -> list[Sample]:
    samples: list[Sample] = []
    deadline = time.monotonic() + timeout_s
    while len(samples) < count and time.monotonic() < deadline:
        samples += inbox.drain()
        time.sleep(0.01)
    return samples


def test_commands_from_a_client_process_arrive_as_remote_samples() -> None:
    inbox = SensorInbox()
    with RemoteServer(inbox) as server:
        client = subprocess.run(
            [
                *(sys.executable, "-m", "beatlog_examples.dog.remote", "--port", str(server.port)),
                *("--for", "0.25", "forward", "0.2", "turn", "-0.5"),
            ],
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
        )
        samples = wait_for(inbox, 4)
    assert client.returncode == 0, client.stderr
    assert [s.sensor for s in samples] == ["remote"] * len(samples)
    values = [s.value for s in samples]
    assert values[:-1] == [(0.2, -0.5, True)] * (len(values) - 1)
    assert len(values) - 1 >= 2  # sent again and again while it drives
    assert values[-1] == (0.0, 0.0, False)


def test_a_dropped_link_sends_the_commands_without_a_release() -> None:
    inbox = SensorInbox()
    with RemoteServer(inbox) as server:
        port = str(server.port)
        assert main(["--port", port, "--for", "0.25", "forward", "0.1", "--no-release"]) == 0
        samples = wait_for(inbox, 3)
    assert len(samples) >= 2
    assert [s.value for s in samples] == [(0.1, 0.0, True)] * len(samples)


def test_commands_are_clamped_to_what_the_dog_can_do() -> None:
    assert RemoteCommand(speed=5.0, turn=-9.0).sample() == (MAX_SPEED, -1.5, True)
    assert RemoteCommand(speed=0.1, release=True).sample() == (0.0, 0.0, False)


def test_lines_that_are_not_commands_are_dropped_and_counted() -> None:
    inbox = SensorInbox()
    with RemoteServer(inbox) as server:
        with socket.create_connection(("127.0.0.1", server.port)) as connection:
            connection.sendall(b'{"speed": 0.1}\nnot json\n{"speed": "fast"}\n')
            connection.sendall(b'{"launch": true}\n' + b"x" * 5000 + b"\n{}\n")
        samples = wait_for(inbox, 2)
    assert [s.value for s in samples] == [(0.1, 0.0, True), (0.0, 0.0, True)]
    assert server.rejected == 4


def test_drive_sends_the_command_repeatedly_then_releases() -> None:
    inbox = SensorInbox()
    with RemoteServer(inbox) as server:
        sent = drive(server.port, 0.1, 0.0, 0.3, rate_hz=20.0)
        samples = wait_for(inbox, sent)
    assert sent >= 2, "the command is sent repeatedly, then released"
    assert len(samples) == sent


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["forward"], "expected pairs"),
        (["jump", "1"], "unknown command 'jump'"),
        (["forward", "fast"], "forward: not a number: 'fast'"),
    ],
)
def test_bad_client_arguments_are_a_usage_error(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["--port", "1", *argv])
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err


def test_a_robot_that_is_not_there_is_one_line_and_exit_code_2(
    capsys: pytest.CaptureFixture[str],
) -> None:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        free_port = probe.getsockname()[1]
    assert main(["--port", str(free_port), "forward", "0.1"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"remote: error: cannot reach 127.0.0.1:{free_port}")
    assert err.count("\n") == 1
