"""The CLI imports only the invoked command's module, and every listed command parses."""
import argparse
import importlib
import subprocess
import sys

import pytest

from ipf_jax.cli import MODULE_COMMANDS, _parser


@pytest.mark.parametrize("name", list(MODULE_COMMANDS))
def test_each_listed_command_is_registered_by_its_module(name):
    module, _ = MODULE_COMMANDS[name]
    sub = argparse.ArgumentParser().add_subparsers(dest="command")
    importlib.import_module(module).add_parser(sub)
    assert name in sub.choices
    p = _parser([name, "--help"])
    action = next(a for a in p._actions if isinstance(a, argparse._SubParsersAction))
    assert action.choices[name].add_help  # the real parser, not the --help placeholder


def test_help_does_not_import_the_heavy_modules():
    code = ("import sys; from ipf_jax.cli import _parser; _parser(['--help']); "
            "print(','.join(m for m in ('jax', 'scipy', 'matplotlib') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""
