"""``python -m marops_cli``: the ``marops`` command, for where the console script is not
on ``PATH`` (a notebook's kernel, a cron job's environment); :func:`run` is the console
script too."""

import sys


def run() -> None:
    """The ``marops`` command (:func:`~marops_cli.cli.app.main`), imported here: Ctrl-C
    while the command line's libraries load, before the command takes Ctrl-C itself (the
    first few tenths of a second), is one line and exit 130 as later on, not the
    traceback of an import."""
    try:
        from .cli.app import main
    except KeyboardInterrupt:
        sys.stderr.write("marops: interrupted\n")
        raise SystemExit(130) from None
    main()


if __name__ == "__main__":
    run()
