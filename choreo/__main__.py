import sys

from choreo.cli import program

sys.exit(program())
