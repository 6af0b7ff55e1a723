"""The shipped actors (policies/README.md), installed as the package ``marops_cli.shipped``."""
