"""``python -m ipf_jax.analysis.singlecam fix-single RUN_DIR --out DIR``."""
import sys

from .cli import main

sys.exit(main())
