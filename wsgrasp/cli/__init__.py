"""The ``wsgrasp`` command.

User errors (``WsgraspError``) are printed as one line on stderr, without a
traceback, and exit with status 2; ``--debug`` shows the traceback too.
"""

from __future__ import annotations

import importlib
import sys

import typer

from wsgrasp.cli._common import console, err_console, state
from wsgrasp.errors import WsgraspError, os_error_message

__all__ = ["app", "main"]

app = typer.Typer(
    name="wsgrasp",
    help="Plan grasps on unknown objects from point clouds, for any gripper.",
    no_args_is_help=True,
    rich_markup_mode=None,
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
    "_batch",
)
for _name in _COMMAND_MODULES:
    importlib.import_module(f"wsgrasp.cli.{_name}").register(app)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``wsgrasp`` console script.

    Exit status: 0 done; 1 a run whose result is "no" (``replay`` differing, a
    failed check) or an internal error; 2 a usage error or a ``WsgraspError``;
    130 interrupted.
    """
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
        _print_error(str(exc))
        return 2
    except typer.Exit as exc:
        return int(exc.exit_code or 0)
    except (typer.Abort, KeyboardInterrupt):
        err_console.print("aborted")
        return 130
    except OSError as exc:
        # a path the user gave (or a folder under it) that cannot be read or
        # written: the path and the fix, not a traceback
        if state.debug:
            err_console.print_exception()
        _print_error(os_error_message(exc))
        return 2
    except Exception as exc:  # noqa: BLE001 - click usage errors and the like
        if _is_usage_error(exc):
            exc.show()  # type: ignore[attr-defined]
            return int(getattr(exc, "exit_code", 2))
        if state.debug:
            raise
        _print_error(
            f"{type(exc).__name__}: {exc} "
            "(run again with --debug for the traceback, and please report it)",
            label="internal error",
        )
        return 1
    return 0


def _print_error(text: str, label: str = "error") -> None:
    from rich.markup import escape

    err_console.print(
        f"[bold red]{label}:[/] {escape(text)}", highlight=False, soft_wrap=True
    )


def _is_usage_error(exc: BaseException) -> bool:
    """click's usage errors, from click itself or the copy vendored by typer."""
    import click

    classes: list[type] = [click.exceptions.ClickException]
    vendored = getattr(typer, "TyperException", None)
    if isinstance(vendored, type):
        classes.append(vendored)
    return isinstance(exc, tuple(classes)) and hasattr(exc, "show")


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())


_ = console  # re-exported for command modules
