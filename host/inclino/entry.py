"""The `inclino` command's entry point (pyproject.toml [project.scripts]).

Ctrl-C is handled from its first line: the command line package, the
library behind it and the option parser are imported and built inside the
handler, so an interruption at any moment -- also while the command is
still starting -- is one line (`inclino: interrupted`) and exit status 130,
never a traceback (docs/cli.md, "Interrupts").  From the moment this module
is imported (the console script's first statement) until main's handler is
in place, a Ctrl-C is held and raised inside it.  An import that a Ctrl-C
cuts short inside a C extension can surface as another exception (numpy's
C core, interrupted while importing datetime, raises ImportError: the
KeyboardInterrupt is lost); after a Ctrl-C such an exception is the
interruption too.  A Ctrl-C that comes while a finaliser runs is sent again
for after it (an exception raised in one is printed and dropped).  This
module imports nothing but the standard library's os, sys and signal."""
import os
import signal
import sys

_state = {"armed": False, "pending": False, "signalled": False}


def _hold(signum, frame):
    _state["signalled"] = True
    if _state["armed"]:
        if _in_finaliser(frame):
            # raised here, Python prints "Exception ignored ... Traceback ... KeyboardInterrupt" and goes on:
            # the signal is sent again, to be handled once the callback has returned
            os.kill(os.getpid(), signum)
            return
        raise KeyboardInterrupt
    _state["pending"] = True


def _in_finaliser(frame) -> bool:
    """Whether a signal came while a finaliser ran: an exception raised there
    is printed and dropped (a module lock's weakref callback, importlib's
    `cb`, caught a Ctrl-C 0.4 s into a refused calibrate: the command went on
    and printed the traceback before its own error line)."""
    code = getattr(frame, "f_code", None)
    return code is not None and (code.co_name == "__del__" or (
        code.co_name == "cb" and code.co_filename.startswith("<frozen importlib")))


if signal.getsignal(signal.SIGINT) is signal.default_int_handler:  # never where SIGINT is ignored
    signal.signal(signal.SIGINT, _hold)


def main(argv=None) -> int:
    try:
        _state["armed"] = True
        if _state["pending"]:
            raise KeyboardInterrupt
        from inclino.cli import main as run

        return run(argv)
    except KeyboardInterrupt:  # while starting (cli.main handles those of the command)
        return _interrupted()
    except Exception:
        if _state["signalled"]:  # an import cut short by the Ctrl-C, reported as something else
            return _interrupted()
        raise
    finally:
        # the command has finished: a Ctrl-C from here on (the interpreter shutting down) is held, not raised
        # where nothing catches it (a module lock's callback printed "Exception ignored ... KeyboardInterrupt"
        # with its traceback when a fast refusal returned 0.4 s after the start and the signal came then)
        _state["armed"] = False


def _interrupted() -> int:
    try:
        sys.stderr.write("inclino: interrupted\n")
        sys.stderr.flush()
    except BaseException:  # interrupted again, or stderr closed
        pass
    return 130


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
