"""``python -m studies COMMAND [OPTIONS]`` from the checkout's root (studies/cli.py)."""

from dpcollapse.cli import entry
from studies.cli import PROG, cli

entry(group=cli, prog_name=PROG)
