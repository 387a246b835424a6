"""The `liaison` command's entry point (pyproject's console script, and `python -m liaison_cli`): the command's
modules are imported here, where a Ctrl-C while they load is one line and exit 130, never a traceback."""

import sys


def run() -> None:
    try:
        from liaison_cli.cli import main
    except KeyboardInterrupt:  # nothing has started, nothing was written
        import signal

        signal.signal(signal.SIGINT, signal.SIG_IGN)
        # CPython marks an interrupt that escaped module code (an import) as unhandled and, at exit, dies by
        # SIGINT instead of exiting 130; an exec() of a string clears the mark (as interrupts.ignore_from_now_on).
        exec("None")  # noqa: S102 - a constant
        print("error: interrupted: nothing was written and no earlier result was replaced; rerun the same command",
              file=sys.stderr)
        sys.exit(130)
    main()


if __name__ == "__main__":
    run()
