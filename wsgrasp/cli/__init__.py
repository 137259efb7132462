"""The ``wsgrasp`` command.

User errors (``WsgraspError``) are printed as one line on stderr, without a
traceback, and exit with status 2; ``--debug`` shows the traceback too.
"""

from __future__ import annotations

import importlib
import sys

import typer

from wsgrasp.cli._common import console, err_console, state
from wsgrasp.errors import WsgraspError

__all__ = ["app", "main"]

app = typer.Typer(
    name="wsgrasp",
    help="Plan grasps on unknown objects from point clouds, for any gripper.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


@app.callback()
def _root(
    debug: bool = typer.Option(False, "--debug", help="Show tracebacks of errors."),
) -> None:
    state.debug = debug


# Each command module adds its commands to ``app`` in ``register(app)``.
_COMMAND_MODULES = (
    "_core",
    "_grippers",
    "_plan",
    "_scene",
    "_record",
    "_eval",
    "_scaffold",
)
for _name in _COMMAND_MODULES:
    importlib.import_module(f"wsgrasp.cli.{_name}").register(app)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``wsgrasp`` console script."""
    args = sys.argv[1:] if argv is None else argv
    state.debug = "--debug" in args
    try:
        # without standalone mode, click returns the code of a typer.Exit
        rv = app(args=args, standalone_mode=False)
        if isinstance(rv, int):
            return rv
    except WsgraspError as exc:
        if state.debug:
            err_console.print_exception()
        err_console.print(f"[bold red]error:[/] {exc}", highlight=False, soft_wrap=True)
        return 2
    except typer.Exit as exc:
        return int(exc.exit_code or 0)
    except typer.Abort:
        err_console.print("aborted")
        return 130
    except Exception as exc:  # noqa: BLE001 - click usage errors and the like
        import click

        if isinstance(exc, click.exceptions.ClickException):
            exc.show()
            return 2
        if state.debug:
            raise
        err_console.print(
            f"[bold red]internal error:[/] {type(exc).__name__}: {exc} "
            "(run again with --debug for the traceback, and please report it)",
            highlight=False,
            soft_wrap=True,
        )
        return 1
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())


_ = console  # re-exported for command modules
