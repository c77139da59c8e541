"""The command line's layout: one module per command, imported only when that command runs; the
list of commands (``mazeslam --help``) says what each command's own help says."""

import subprocess
import sys

import click
import pytest

from mazeslam.cli.lazy import LazyCommand
from mazeslam.cli.main import COMMANDS, main


@pytest.mark.parametrize(("name", "module", "attribute"), COMMANDS)
def test_the_listed_help_is_the_commands_own(name, module, attribute):
    stand_in = LazyCommand(name, module, attribute)  # fresh: the group swaps in a command once it ran
    command = stand_in.load()
    assert isinstance(command, click.Command) and command.name == name and name in main.commands
    assert stand_in.get_short_help_str() == command.get_short_help_str()
    assert module == f"mazeslam.cli.{name.replace('-', '_')}" or name == "import"


def test_the_list_of_commands_loads_no_command():
    code = (
        "import sys\nfrom mazeslam.cli.main import main\n"
        "try:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
        "heavy = ('scipy', 'matplotlib', 'pandas')\n"
        "print(sorted(m for m in sys.modules if m.startswith('mazeslam.cli.') or m in heavy))"
    )
    output = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert output.strip().splitlines()[-1] == "['mazeslam.cli.lazy', 'mazeslam.cli.main']"
