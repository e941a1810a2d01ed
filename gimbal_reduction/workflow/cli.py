"""What the stages' command lines share: one-line argument errors, negative numbers read as
values, the output location checked before the work, and a failed write reported in one line.

* ``OneLineParser``: an ``argparse.ArgumentParser`` whose errors are one line
  (``prog: message (see --help)``, exit status 2) instead of a usage block.
* ``values_joined(argv, parser)``: ``--step -1e-6`` becomes ``--step=-1e-6`` for every
  option that takes a value, so argparse reads a negative number (``-1e-6`` does not match
  argparse's own negative-number pattern) as the option's value, and the option's type
  refuses it with a message naming the option, instead of "expected one argument".
* ``positive_number(name)``, ``positive_int(name)``: argparse types of a positive finite
  float / positive integer.
* ``add_config_option(parser, what)``: ``--config FILE``, the configuration in use, by default
  the run's (``config/config.yaml`` of the working directory, else the project's): a stage
  always checks the files it reads against it, with no flag to remember.
* ``check_writable(path)``: ValueError (one line) before any work if ``path`` could not be
  written; nothing is created.
* ``write_failure(path, exc)``: the one-line message of an OSError while writing ``path``
  (a full disk, a quota, a folder made read-only meanwhile); the atomic writers of
  ``gimbal_reduction.workflow.provenance`` have removed their temporary file by then, so nothing is left.
"""
from __future__ import annotations

import argparse
import errno
import math
import os

from gimbal_reduction.workflow.provenance import run_config


class OneLineParser(argparse.ArgumentParser):
    """Argument errors as one line (no usage block), exit status 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: {message} (see --help)\n")


def _takes_value(parser: argparse.ArgumentParser, option: str) -> bool:
    action = parser._option_string_actions.get(option)      # noqa: SLF001 - argparse's own table
    return action is not None and action.nargs is None and action.option_strings and \
        not isinstance(action, (argparse._StoreTrueAction, argparse._StoreFalseAction,  # noqa: SLF001
                                argparse._StoreConstAction, argparse._HelpAction))      # noqa: SLF001


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def values_joined(argv, parser: argparse.ArgumentParser) -> list[str]:
    """``argv`` with ``--opt -1e-6`` joined into ``--opt=-1e-6`` for every single-value option of
    ``parser`` followed by a negative number (or ``-inf``/``-nan``)."""
    argv = list(argv)
    out, i = [], 0
    while i < len(argv):
        token = argv[i]
        if (i + 1 < len(argv) and token.startswith("--") and "=" not in token
                and _takes_value(parser, token) and argv[i + 1].startswith("-")
                and _is_number(argv[i + 1])):
            out.append(f"{token}={argv[i + 1]}")
            i += 2
            continue
        out.append(token)
        i += 1
    return out


def positive_number(name: str):
    """argparse type: a positive finite float; a negative, zero or non-finite value is refused
    naming the option."""
    def parse(text):
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a number, got {text!r}") from None
        if not (math.isfinite(value) and value > 0):
            raise argparse.ArgumentTypeError(f"{name} must be a positive finite number, got {text!r}")
        return value
    return parse


def positive_int(name: str):
    """argparse type: a positive integer (``1e6`` accepted when it is a whole number)."""
    def parse(text):
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a whole number, got {text!r}") from None
        if not (math.isfinite(value) and value >= 1 and value == int(value)):
            raise argparse.ArgumentTypeError(f"{name} must be a positive whole number, got {text!r}")
        return int(value)
    return parse


def add_config_option(parser: argparse.ArgumentParser, what: str) -> None:
    """``--config FILE`` on ``parser``: the configuration the stage's input files must have been
    made from (``what`` says which); by default the run's own, ``config/config.yaml`` of the
    working directory, else the project's (``gimbal_reduction.workflow.provenance.run_config``)."""
    parser.add_argument("--config", default=str(run_config()),
                        help=f"the configuration in use (default: config/config.yaml of the working "
                             f"directory, else the project's): {what}")


def check_writable(path) -> None:
    """ValueError (one line) before the work if ``path`` could not be written: it must not be a
    folder, and its folder, or the nearest existing folder above it, must be a writable folder.
    Nothing is created here (the folder appears only with the file)."""
    path = os.path.abspath(str(path))
    if os.path.isdir(path):
        raise ValueError(f"output {path} is a folder, not a file")
    folder = os.path.dirname(path)
    existing = folder
    while not os.path.isdir(existing):
        if os.path.exists(existing):
            raise ValueError(f"cannot create the output folder {folder}: {existing} is a file")
        existing = os.path.dirname(existing)
    if not os.access(existing, os.W_OK | os.X_OK):
        raise ValueError(f"output folder {existing} is not writable (for {path})")
    if os.path.exists(path) and not os.access(path, os.W_OK) and not os.access(folder, os.W_OK):
        raise ValueError(f"output {path} cannot be replaced (read-only)")


def write_failure(path, exc: BaseException) -> str:
    """One-line message of a failed write of ``path``."""
    code = getattr(exc, "errno", None)
    if code is None and "no space left" in str(exc).lower():       # h5py's wrapped errno 28
        code = errno.ENOSPC
    if code == errno.ENOSPC:
        why = "no space left on the device"
    elif code == errno.EDQUOT:
        why = "disk quota exceeded"
    elif code in (errno.EACCES, errno.EPERM, errno.EROFS):
        why = "permission denied"
    else:
        why = " ".join(str(exc).split()) or exc.__class__.__name__
    return f"cannot write {path}: {why}; nothing was written (free space or choose another --out, then rerun)"
