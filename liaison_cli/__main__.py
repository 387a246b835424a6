"""The `liaison` command's entry point (pyproject's console script, and `python -m liaison_cli`): the command's
modules are imported here, where a Ctrl-C while they load is one line and exit 130, never a traceback."""

import sys


def run() -> None:
    try:
        from liaison_cli.cli import main
    except KeyboardInterrupt:  # nothing has started, nothing was written
        from liaison_cli import interrupts  # the standard library only: it loads where the CLI did not

        # Also clears CPython's mark of an interrupt that escaped module code, which would otherwise end the
        # process by SIGINT instead of exit 130.
        interrupts.ignore_from_now_on()
        print(f"error: {interrupts.INTERRUPTED_MESSAGE}", file=sys.stderr)
        sys.exit(130)
    main()


if __name__ == "__main__":
    run()
