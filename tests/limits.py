"""A time limit for one test step: a hang fails the step instead of the suite."""

import contextlib
import signal


class Hang(Exception):
    """No answer within the time limit."""


@contextlib.contextmanager
def time_limit(seconds: int):
    """Raise `Hang` in this (main) thread if the block runs longer than `seconds`."""

    def alarm(signum, frame):
        raise Hang(f"no answer within {seconds} s")

    previous = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
