"""The argument parser of the ``pelcs`` command line: no abbreviations, "did you mean".

argparse accepts any unambiguous prefix of a long option (``--out`` for ``--output``), which
silently changes meaning when a later version adds an option with the same prefix, and it
reports a misspelt option only as "unrecognized arguments" (or, when the misspelt option is a
required one, as that option missing). :class:`Parser` refuses prefixes and names the closest
option of the command that was run.
"""

from __future__ import annotations

import argparse


class Parser(argparse.ArgumentParser):
    """An :class:`argparse.ArgumentParser` without abbreviations whose unknown options get a
    "did you mean". Subcommand parsers made by ``add_subparsers().add_parser`` are of this
    class too (argparse makes them of the parent's class)."""

    def __init__(self, *args, **kwargs) -> None:
        kwargs["allow_abbrev"] = False
        super().__init__(*args, **kwargs)
        self._argv: list[str] = []

    def parse_known_args(self, args=None, namespace=None):  # noqa: D102 - argparse's
        self._argv = [str(a) for a in args] if args is not None else []
        return super().parse_known_args(args, namespace)

    def parse_args(self, args=None, namespace=None):  # noqa: D102 - argparse's
        namespace, extras = self.parse_known_args(args, namespace)
        if extras:
            parser = self._command_parser(namespace)
            parser._refuse_unknown(extras)
            parser.error(f"unrecognized arguments: {' '.join(extras)}")
        return namespace

    def error(self, message: str):  # noqa: D102 - argparse's
        # A misspelt required option is reported as missing: name the misspelling instead.
        if message.startswith("the following arguments are required"):
            self._refuse_unknown(self._argv)
        super().error(message)

    def _refuse_unknown(self, args: list[str]) -> None:
        """Exit with "unrecognized option" and the closest option, if ``args`` has an option
        this parser does not know."""
        for arg in args:
            if not arg.startswith("-") or arg == "-" or arg == "--" or \
                    self._negative_number_matcher.match(arg):
                continue
            name = arg.split("=", 1)[0]
            if name in self._option_string_actions:
                continue
            import difflib  # (only for a mistyped option)

            close = difflib.get_close_matches(name, list(self._option_string_actions), n=1)
            guess = (f"; did you mean '{close[0]}'?" if close else
                     f"; `{self.prog} --help` lists the options")
            super().error(f"unrecognized option '{name}'{guess}")

    def _command_parser(self, namespace: argparse.Namespace) -> Parser:
        """The parser of the subcommand that was run (this one without a subcommand)."""
        for action in self._actions:
            if isinstance(action, argparse._SubParsersAction):
                chosen = action.choices.get(getattr(namespace, action.dest, None) or "")
                if chosen is not None:
                    return chosen
        return self
