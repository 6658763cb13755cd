"""``python -m ipf_jax.singlecam fix-single RUN_DIR --out DIR``."""
import sys

from .cli import main

sys.exit(main())
