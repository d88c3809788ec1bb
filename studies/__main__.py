"""``python -m studies COMMAND [OPTIONS]`` from the checkout's root (studies/cli.py)."""

from studies.cli import PROG, cli
from dpcollapse.cli import entry

entry(group=cli, prog_name=PROG)
