"""The conventions every command line of spine_gym shares (``spine-gym <command>`` and the
``python -m`` modules behind it).

* :data:`PROG` — the program name, ``spine-gym`` (a command's is ``spine-gym <command>``), and
  :func:`module_prog` — the ``python -m <module>`` name each command also runs under;
* :class:`Parser` — argparse with one-line usage errors (exit status 2, before any side effect),
  the defaults shown in ``--help``, an ``examples:`` epilog (a module's ``EXAMPLES`` text block,
  one command a line) and no abbreviated options (``--n-timestep`` is not ``--n-timesteps``);
* :func:`add_env` — ``--env`` with the registered spine ids as choices, a misspelt id answered with
  "did you mean ...";
* :class:`KeyValues` — ``--env-kwargs``/``--hyperparams`` pairs as ``key=value`` or RL Zoo's
  ``key:value`` (values are Python literals where they parse as one);
* :func:`add_out`, :func:`add_progress`, :func:`add_workers` — ``-o/--out``,
  ``--progress/--no-progress`` and ``--workers``;
* :func:`check_env_kwargs`, :func:`check_keys`, :func:`check_file`, :func:`check_out_dir`,
  :func:`check_out_file` — the checks a command runs on its arguments before it creates a folder or
  starts work (``ValueError`` with a one-line message, which the command passes to
  ``parser.error``, e.g. with :func:`usage_errors`);
* :func:`plain_text` — a docstring line without its reST markup, as ``--help`` prints it.
"""

from __future__ import annotations

import argparse
import ast
import contextlib
import difflib
import inspect
import os
import re
import tempfile
import textwrap
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
from gymnasium.envs.registration import load_env_creator

from spine_gym.envs import ENV_SPECS, config_of  # registers the spine envs

__all__ = [
    "PROG",
    "module_prog",
    "ENV_IDS",
    "HelpFormatter",
    "Parser",
    "KeyValues",
    "parse_value",
    "did_you_mean",
    "env_id",
    "add_env",
    "add_env_kwargs",
    "add_out",
    "add_progress",
    "add_workers",
    "check_env_kwargs",
    "check_keys",
    "check_file",
    "check_out_dir",
    "check_out_file",
    "positive_int",
    "plain_text",
    "first_line",
    "usage_errors",
]

#: the program name of the command line (``spine-gym <command>`` for a command)
PROG = "spine-gym"


def module_prog(module: str) -> str:
    """The ``python -m`` program name of a command's module (a package's ``__main__``: the package)."""
    return "python -m " + module.removesuffix(".__main__")


#: every registered spine env id (the ``--env`` choices)
ENV_IDS: tuple[str, ...] = tuple(i for i in gym.envs.registry if "Spine" in i) or tuple(ENV_SPECS)


_ROLE = re.compile(r":[a-z]+(?::[a-z]+)?:`~?([^`<]*?)(?:\s*<[^>]*>)?`")  # :mod:`x`, :func:`~a.b`
_LITERAL = re.compile(r"``([^`]+)``")


def plain_text(text: str) -> str:
    """``text`` without reST markup: a literal in double backquotes -> its text, a role such as
    ``:mod:`a.b``` -> ``a.b`` and ``:func:`~a.b``` -> ``b`` (``--help`` is read in a terminal)."""

    def role(m: re.Match) -> str:
        target = m.group(1)
        return target.rsplit(".", 1)[-1] if m.group(0).split("`", 1)[1].startswith("~") else target

    return _LITERAL.sub(r"\1", _ROLE.sub(role, text))


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """Each option's default after its help (unless the help names it already or there is none to
    show); the description and the examples epilog are printed as written, without reST markup."""

    def _format_text(self, text: str) -> str:
        return super()._format_text(plain_text(text))

    def _get_help_string(self, action: argparse.Action) -> str:
        text = plain_text(action.help or "")
        nothing = action.default is None or action.default is False  # (0 is a default to show)
        if "default" in text.lower() or nothing or action.default in ("", [], {}, argparse.SUPPRESS):
            return text
        return super()._get_help_string(action)


class Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors (``<prog>: error: <message>`` on stderr, exit status 2),
    :class:`HelpFormatter`, ``examples`` as the epilog (commands: a text block with one a line,
    or a sequence of lines) and options only by their full names (``allow_abbrev=False``)."""

    def __init__(self, *args, examples: str | Sequence[str] = (), **kwargs):
        kwargs.setdefault("formatter_class", HelpFormatter)
        kwargs.setdefault("allow_abbrev", False)
        if "\n" not in kwargs.get("description", "\n"):
            kwargs["description"] = textwrap.fill(kwargs["description"], 100)
        lines = examples.strip("\n").splitlines() if isinstance(examples, str) else examples
        if lines:
            kwargs["epilog"] = "examples:\n" + "\n".join(f"  {e}" for e in lines)
        super().__init__(*args, **kwargs)

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {first_line(message)}\n")


@contextlib.contextmanager
def usage_errors(parser: argparse.ArgumentParser) -> Iterator[None]:
    """A ``ValueError`` raised in the block becomes ``parser.error`` (a usage error, exit status 2)."""
    try:
        yield
    except ValueError as e:
        parser.error(str(e))


def first_line(message: object) -> str:
    """The first non-empty line of ``message`` (an exception's text can run over several)."""
    lines = [s.strip() for s in str(message).splitlines() if s.strip()]
    return lines[0] if lines else ""


def parse_value(text: str) -> Any:
    """A ``key=value`` value: a Python literal if it parses as one, else the string itself."""
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return text


def split_pair(item: str) -> tuple[str, str]:
    """``key=value`` or ``key:value`` split at the first ``=`` or ``:`` (keys hold neither)."""
    cuts = [i for i in (item.find("="), item.find(":")) if i > 0]
    if not cuts:
        raise ValueError(f"expected key=value (or key:value), got {item!r}")
    return item[: min(cuts)], item[min(cuts) + 1 :]


class KeyValues(argparse.Action):
    """argparse action that turns ``k1=v1 k2:v2`` into ``{"k1": v1, "k2": v2}`` (both separators,
    the second is RL Zoo's)."""

    def __call__(self, parser, namespace, values, option_string=None):
        out = {}
        for item in values:
            try:
                key, value = split_pair(item)
            except ValueError as e:
                raise argparse.ArgumentError(self, str(e)) from None
            out[key] = parse_value(value)
        setattr(namespace, self.dest, out)


def did_you_mean(word: str, options: Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` for the closest of ``options`` to ``word`` (case-blind), else ``""``."""
    by_lower = {o.lower(): o for o in options}
    close = difflib.get_close_matches(word.lower(), list(by_lower), n=1, cutoff=0.6)
    return f" (did you mean {by_lower[close[0]]!r}?)" if close else ""


def env_id(text: str) -> str:
    """argparse ``type`` of ``--env``: a registered spine env id."""
    if text in ENV_IDS:
        return text
    raise argparse.ArgumentTypeError(
        f"unknown env id {text!r}{did_you_mean(text, ENV_IDS)}; choose from {', '.join(ENV_IDS)}"
    )


def add_env(p: argparse.ArgumentParser, *flags: str, default: Any = None, **kwargs) -> argparse.Action:
    """``--env`` (and ``flags``) with the registered spine env ids as choices."""
    kwargs.setdefault("help", "environment id, one of: " + ", ".join(ENV_IDS))
    return p.add_argument(
        "--env", *flags, type=env_id, choices=ENV_IDS, metavar="ID", default=default, **kwargs
    )


def add_env_kwargs(p: argparse.ArgumentParser, nargs: str = "+", default: Any = None, **kwargs):
    """``--env-kwargs k=v ...`` (``k:v`` also accepted): keyword arguments of the env."""
    kwargs.setdefault("help", "env keyword arguments key=value (key:value also accepted)")
    return p.add_argument(
        "--env-kwargs", nargs=nargs, action=KeyValues, default={} if default is None else default,
        metavar="KEY=VALUE", **kwargs,
    )  # fmt: skip


def add_out(p: argparse.ArgumentParser, *aliases: str, default: Any = None, **kwargs) -> argparse.Action:
    """``-o/--out`` (and ``aliases``): the output folder."""
    kwargs.setdefault("help", "output folder")
    kwargs.setdefault("metavar", "DIR")
    return p.add_argument("-o", "--out", *aliases, default=default, **kwargs)


def add_progress(p: argparse.ArgumentParser, *aliases: str, default: bool = True) -> argparse.Action:
    """``--progress/--no-progress`` (and ``aliases`` for ``--progress``)."""
    return p.add_argument(
        *aliases, "--progress", action=argparse.BooleanOptionalAction, default=default,
        help=f"show progress (default: {'on' if default else 'off'})",
    )  # fmt: skip


def positive_int(text: str) -> int:
    """argparse ``type`` of a count: an integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1, got {value}")
    return value


def all_or_positive_int(text: str) -> int:
    """argparse ``type`` of a worker count that may be ``-1`` (all cores): -1 or an integer >= 1."""
    if text.strip() == "-1":
        return -1
    try:
        return positive_int(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(f"must be -1 (all cores) or an integer >= 1, got {text!r}") from None


def add_workers(
    p: argparse.ArgumentParser, *aliases: str, default: Any = 1, all_cores: bool = False, **kwargs
) -> argparse.Action:
    """``--workers`` (and ``aliases``): how many processes or threads share the work, >= 1 (or -1,
    all cores, with ``all_cores``)."""
    kwargs.setdefault("help", "parallel workers")
    kwargs.setdefault("metavar", "N")
    kind = all_or_positive_int if all_cores else positive_int
    return p.add_argument("--workers", *aliases, type=kind, default=default, **kwargs)


def env_parameters(env: str) -> tuple[str, ...] | None:
    """The keyword arguments the class of ``env`` takes (None: it takes any)."""
    params = inspect.signature(load_env_creator(gym.spec(env).entry_point)).parameters
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
        return None
    return tuple(params)


def check_env_kwargs(env: str, env_kwargs: dict, flag: str = "--env-kwargs") -> None:
    """ValueError (one line) unless ``env`` takes ``env_kwargs``: the names are checked against its
    class, then its configuration is validated (:func:`spine_gym.envs.config_of`, the checks the
    env makes; no env is built) so that the values are checked too."""
    accepted = env_parameters(env)
    for key in env_kwargs:
        if accepted is not None and key not in accepted:
            raise ValueError(f"{flag}: {env} takes no argument {key!r}{did_you_mean(key, accepted)}")
    try:
        config_of(env, **env_kwargs)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{flag}: not accepted by {env}: {first_line(e)}") from None


def check_keys(keys: Iterable[str], allowed: Iterable[str], flag: str, what: str = "key") -> None:
    """ValueError (one line) naming the first of ``keys`` that is not ``allowed`` (``what``: the
    word for a key in the message)."""
    allowed = sorted(allowed)
    for key in keys:
        if key not in allowed:
            hint = did_you_mean(key, allowed)
            raise ValueError(f"{flag}: unknown {what} {key!r}{hint}; allowed: {', '.join(allowed)}")


def check_file(path: str | Path, flag: str) -> None:
    """ValueError (one line) unless ``path`` exists."""
    if not Path(path).exists():
        raise ValueError(f"{flag}: {path} does not exist")


def _writable(folder: Path) -> bool:
    """Whether a file can be made in ``folder``, by a real probe: the permission bits say yes to root
    on read-only and virtual file systems (``/proc``). The probe file is removed at once."""
    if not os.access(folder, os.W_OK | os.X_OK):
        return False
    try:
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".spine-gym-probe-"):
            return True
    except OSError:
        return False


def check_out_dir(path: str | Path, flag: str = "-o/--out") -> None:
    """ValueError (one line) unless ``path`` is a writable folder or one that can be created (its
    nearest existing ancestor is a writable folder). Nothing is created."""
    target = Path(path).expanduser()
    if target.exists():
        if not target.is_dir():
            raise ValueError(f"{flag}: {path} is a file, not a folder")
        if not _writable(target):
            raise ValueError(f"{flag}: {path} is not writable")
        return
    ancestor = target.absolute().parent
    while not ancestor.exists():
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise ValueError(f"{flag}: cannot create {path}: {ancestor} is a file")
    if not _writable(ancestor):
        raise ValueError(f"{flag}: cannot create {path}: {ancestor} is not writable")


def check_out_file(path: str | Path, flag: str = "-o/--out") -> None:
    """ValueError (one line) unless the file ``path`` can be written: not a folder, and its folder
    writable or creatable (:func:`check_out_dir`). Nothing is created."""
    target = Path(path).expanduser()
    if target.is_dir():
        raise ValueError(f"{flag}: {path} is a folder, not a file")
    if target.exists() and not os.access(target, os.W_OK):
        raise ValueError(f"{flag}: {path} is not writable")
    try:
        check_out_dir(target.parent, flag)
    except ValueError as e:
        raise ValueError(f"{flag}: cannot write {path}: {str(e).split(': ', 1)[1]}") from None
