"""Remote motion control over loopback TCP: a server inside the robot and a client process.

The protocol is one JSON object per line: ``{"speed": 0.2, "turn": 0.5}`` drives,
``{"release": true}`` hands control back to the dog's own behaviors. The server
pushes each command into the sensor inbox as a ``remote`` sample, so remote control
is sensor input and is recorded like any sensor. Lines that are not a valid command
are counted and dropped; nothing received is ever executed.

Drive the dog from a shell while it records::

    python -m beatlog_examples.dog.remote --port 5555 --for 3 forward 0.2 turn 0.5

``--no-release`` stops sending without the release, as a dropped link would; the dog
goes back to its own behaviors once commands stop coming.
"""

from __future__ import annotations

import argparse
import socket
import sys
import threading
import time
from collections.abc import Sequence
from types import TracebackType

import msgspec

from beatlog.model.inbox import SensorInbox

__all__ = ["RemoteCommand", "RemoteServer", "drive", "main"]

MAX_SPEED = 0.3
MAX_TURN = 1.5
MAX_LINE = 1024


class RemoteCommand(msgspec.Struct, forbid_unknown_fields=True):
    """One line from the client: a drive command, or a release."""

    speed: float = 0.0
    turn: float = 0.0
    release: bool = False

    def sample(self) -> tuple[float, float, bool]:
        """The ``remote`` sample: speed and turn within the dog's limits, and whether active."""
        if self.release:
            return (0.0, 0.0, False)
        speed = max(-MAX_SPEED, min(MAX_SPEED, self.speed))
        return (speed, max(-MAX_TURN, min(MAX_TURN, self.turn)), True)


_decode = msgspec.json.Decoder(RemoteCommand).decode


class RemoteServer:
    """Accepts remote-control clients on a loopback port; a context manager.

    :param port: the TCP port, or 0 for one the OS picks (:attr:`port` once started).
    """

    def __init__(self, inbox: SensorInbox, *, port: int = 0, host: str = "127.0.0.1") -> None:
        self.inbox = inbox
        self.rejected = 0
        self.port = port
        self._host = host
        self._socket: socket.socket | None = None
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []

    def start(self) -> None:
        """Open the port and accept clients in a background thread."""
        self._socket = socket.create_server((self._host, self.port))
        self._socket.settimeout(0.1)
        self.port = self._socket.getsockname()[1]
        self._stop.clear()
        thread = threading.Thread(target=self._accept, name="dog-remote", daemon=True)
        self._threads = [thread]
        thread.start()

    def stop(self) -> None:
        """Stop accepting, let the client threads finish, close the port."""
        self._stop.set()
        for thread in list(self._threads):
            thread.join()
        if self._socket is not None:
            self._socket.close()
            self._socket = None

    def __enter__(self) -> RemoteServer:
        self.start()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.stop()

    def _accept(self) -> None:
        assert self._socket is not None
        while not self._stop.is_set():
            try:
                connection, _address = self._socket.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            client = threading.Thread(
                target=self._serve, args=(connection,), name="dog-remote-client", daemon=True
            )
            self._threads.append(client)
            client.start()

    def _serve(self, connection: socket.socket) -> None:
        connection.settimeout(0.1)
        pending = b""
        overlong = False  # dropping the rest of a line that grew too long
        with connection:
            while not self._stop.is_set():
                try:
                    chunk = connection.recv(4096)
                except TimeoutError:
                    continue
                except OSError:
                    return
                if not chunk:
                    return
                pending += chunk
                *lines, pending = pending.split(b"\n")
                for line in lines:
                    if overlong:
                        overlong = False
                    else:
                        self._receive(line)
                if len(pending) > MAX_LINE:
                    self.rejected += not overlong
                    overlong = True
                    pending = b""

    def _receive(self, line: bytes) -> None:
        if not line.strip():
            return
        try:
            command = _decode(line)
        except msgspec.DecodeError:
            self.rejected += 1
            return
        self.inbox.push("remote", command.sample())


def drive(
    port: int,
    speed: float,
    turn: float,
    seconds: float,
    *,
    host: str = "127.0.0.1",
    rate_hz: float = 10.0,
    release: bool = True,
) -> int:
    """Send a drive command ``rate_hz`` times a second for ``seconds``, then release.

    Returns how many commands were sent.
    """
    line = msgspec.json.encode(RemoteCommand(speed=speed, turn=turn)) + b"\n"
    sent = 0
    with socket.create_connection((host, port), timeout=5.0) as connection:
        due = time.monotonic()
        end = due + seconds
        while True:
            connection.sendall(line)
            sent += 1
            due += 1.0 / rate_hz
            if due >= end:
                break
            time.sleep(max(0.0, due - time.monotonic()))
        time.sleep(max(0.0, end - time.monotonic()))
        if release:
            connection.sendall(msgspec.json.encode(RemoteCommand(release=True)) + b"\n")
            sent += 1
    return sent


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m beatlog_examples.dog.remote",
        description="Drive the robot dog over its loopback remote-control port.",
    )
    parser.add_argument("--port", type=int, required=True, help="the robot's remote port")
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--for", dest="seconds", type=float, default=1.0, help="seconds")
    parser.add_argument(
        "words",
        nargs="*",
        metavar="forward M/S | turn RAD/S",
        help="e.g. 'forward 0.2 turn 0.5'; nothing releases the dog at once",
    )
    parser.add_argument(
        "--no-release",
        dest="release",
        action="store_false",
        help="stop without releasing the dog, as a dropped link would",
    )
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """The client command: 0 when the commands were sent, 2 on bad input."""
    parser = _parser()
    args = parser.parse_args(argv)
    values = {"forward": 0.0, "turn": 0.0}
    words = list(args.words)
    if len(words) % 2:
        parser.error("expected pairs: forward M/S, turn RAD/S")
    for key, text in zip(words[::2], words[1::2], strict=True):
        if key not in values:
            parser.error(f"unknown command {key!r} (use forward, turn)")
        try:
            values[key] = float(text)
        except ValueError:
            parser.error(f"{key}: not a number: {text!r}")
    seconds = args.seconds if words else 0.0
    try:
        drive(
            args.port,
            values["forward"],
            values["turn"],
            seconds,
            host=args.host,
            release=args.release,
        )
    except OSError as exc:
        print(f"remote: error: cannot reach {args.host}:{args.port}: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
