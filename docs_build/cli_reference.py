"""The command-line reference page, generated from the argparse parser.

Every subcommand of ``granular-chain`` with its usage line, description and one
row per argument (flags, metavar, default, help), read from the parser object
itself, so the page always matches ``granular-chain SUBCOMMAND --help``.
"""

from __future__ import annotations

import argparse
import os


def build_parser() -> argparse.ArgumentParser:
    """The parser of the ``granular-chain`` command (the one place this page
    learns where the parser lives)."""
    from granular_chain.cli.main import build_parser as build
    return build()


def subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """The subcommand parsers by name, in the order they were added."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def _help_of(parser: argparse.ArgumentParser) -> dict[str, str]:
    """The one-line help each subcommand was added with."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return {a.dest: a.help or "" for a in action._choices_actions}
    return {}


def _flags(action: argparse.Action) -> str:
    if not action.option_strings:
        return f"`{action.metavar or action.dest}`"
    names = list(action.option_strings)
    takes_value = action.nargs != 0 and not isinstance(action, argparse.BooleanOptionalAction)
    if takes_value:
        metavar = action.metavar or action.dest.upper()
        if isinstance(metavar, tuple):
            metavar = " ".join(metavar)
        names = [f"{n} {metavar}" for n in names]
    return ", ".join(f"`{n}`" for n in names)


def _default(action: argparse.Action) -> str:
    if action.required or not action.option_strings:
        return "required" if action.nargs not in ("?", "*") else "-"
    if action.default in (None, argparse.SUPPRESS) or action.nargs == 0:
        return "-"
    return f"`{action.default}`"


def _choices(action: argparse.Action) -> str:
    return ", ".join(f"`{c}`" for c in action.choices) if action.choices else ""


def _cell(text: str | None) -> str:
    text = " ".join((text or "").split())
    return text.replace("|", "\\|").replace("%%", "%")


def argument_rows(parser: argparse.ArgumentParser) -> list[str]:
    """One table row per argument of ``parser`` (help and version actions left out)."""
    rows = []
    for action in parser._actions:
        if isinstance(action, (argparse._HelpAction, argparse._SubParsersAction)):
            continue
        help_text = action.help if action.help != argparse.SUPPRESS else ""
        if help_text and "%(" in help_text:
            help_text = help_text % {"default": action.default, "prog": parser.prog}
        choices = _choices(action)
        if choices:
            help_text = f"{help_text or ''} (one of {choices})".strip()
        rows.append(f"| {_flags(action)} | {_default(action)} | {_cell(help_text)} |")
    return rows


def _table(parser: argparse.ArgumentParser) -> list[str]:
    rows = argument_rows(parser)
    if not rows:
        return ["No arguments.", ""]
    return ["| argument | default | meaning |", "|---|---|---|", *rows, ""]


def render() -> str:
    """The whole CLI reference page (markdown)."""
    os.environ.setdefault("COLUMNS", "100")  # usage lines wrapped the same on every machine
    parser = build_parser()
    helps = _help_of(parser)
    lines = ["# CLI reference", "",
             "Generated from the command's argparse parser when the site is built; "
             "`granular-chain SUBCOMMAND --help` prints the same. "
             "`python -m granular_chain` is the same command.", "",
             "```text", parser.format_usage().strip(), "```", "",
             "Exit status: 0 success, 1 a run that ended without success, 2 bad input "
             "(one line on stderr), 130 interrupted (Ctrl-C), 143 terminated (SIGTERM).", "",
             *_table(parser)]
    for name, sub in subcommands(parser).items():
        lines += [f"## `{name}`", "", _cell(helps.get(name, "")) + ".", ""]
        if sub.description and sub.description != helps.get(name):
            lines += [sub.description.strip(), ""]
        lines += ["```text", sub.format_usage().strip(), "```", "", *_table(sub)]
        if sub.epilog:
            lines += [sub.epilog.strip(), ""]
    return "\n".join(lines)


if __name__ == "__main__":
    print(render())
