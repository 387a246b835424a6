"""The root command's click group (root.py: `typer.Typer(cls=LiaisonGroup)`): what every command shares in its
parsing, set once on the tree typer builds instead of in each command's signature.

- A flag takes no value, so `--help` shows none: typer's rich help prints a `<bool>` type beside every flag
  (`--overwrite <bool>` reads as if it wanted `--overwrite true`); flags get an empty metavar instead.
- `-v/--verbose` works after the command too (`liaison run X -v`, as `liaison -v run X`): every command gets
  the flag, which raises the `liaison` logger to its -v level when given. The root option stays for
  `--version -v`.
"""

import logging

from typer.core import TyperGroup, TyperOption

VERBOSE_HELP = "Also print progress details on stderr, as `liaison -v COMMAND` (e.g. each stage's time)."


def _verbose_after_command(ctx, param, value: bool) -> bool:
    """The root callback has set the logger's level already (click runs it before parsing the command's
    options); -v given after the command raises it."""
    if value and not ctx.resilient_parsing:
        logging.getLogger("liaison").setLevel(logging.DEBUG)
    return value


def _flags_without_metavar(params) -> None:
    for param in params:
        if getattr(param, "is_flag", False) and param.metavar is None:
            param.metavar = ""  # typer's rich help shows the metavar in place of the type: nothing


def _verbose_option(like: TyperOption) -> TyperOption:
    """A command's own -v/--verbose: the root option's type, not passed to the command's function."""
    return TyperOption(param_decls=["-v", "--verbose"], type_descriptor=like.type_descriptor, is_flag=True,
                       default=False, expose_value=False, callback=_verbose_after_command, help=VERBOSE_HELP,
                       metavar="")


def _prepare(command, verbose: TyperOption) -> None:
    """Every command below `command` (sub-groups included): flags without a metavar (its --help too: click makes
    that option once per command, on first use), and -v on each leaf."""
    _flags_without_metavar(command.get_params(command.context_class(command, info_name=command.name)))
    subcommands = getattr(command, "commands", None)
    if subcommands is None:
        if not any("-v" in param.opts for param in command.params):
            command.params.append(_verbose_option(verbose))
        return
    for sub in subcommands.values():
        _prepare(sub, verbose)


class LiaisonGroup(TyperGroup):
    """typer builds the whole tree (commands and sub-groups) before this root group: it is finished here."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        _flags_without_metavar(self.params)
        verbose = next(param for param in self.params if param.name == "verbose")
        for command in self.commands.values():
            _prepare(command, verbose)

    def get_params(self, ctx):
        """The root's own, with the options typer adds after building it (shell completion) and --help."""
        params = super().get_params(ctx)
        _flags_without_metavar(params)
        return params
