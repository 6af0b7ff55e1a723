"""``python -m marops_cli``: the ``marops`` command, for where the console script is not
on ``PATH`` (a notebook's kernel, a cron job's environment)."""

from .cli.app import main

if __name__ == "__main__":
    main()
