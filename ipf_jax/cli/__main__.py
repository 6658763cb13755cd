"""``python -m ipf_jax.cli``: the same as the ``ipf-jax`` command."""
import sys

from .main import main

sys.exit(main())
