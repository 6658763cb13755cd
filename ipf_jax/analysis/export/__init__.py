"""Export of tracking results: TRC (OpenSim), C3D (Mokka, Vicon), BVH (Blender), CSV.

One module per format over one run-directory reader (:mod:`.rundir`) and one change of axes and
units (:mod:`.axes`); :mod:`ipf_jax.cli.export` is the ``ipf-jax export`` sub-command. See ``docs/export.md``.
"""
from ...data.rundir import (
           Run,
           joints_from_poses,
           read_run,
           sample_rate,
           write_run_dir,
)
from ...data.runfiles import write_rows
from .axes import file_rotation, to_file_frame
from .bvh import SKELETON, export_bvh
from .bvh_reader import BvhFile, bvh_positions, read_bvh
from .c3d import export_c3d
from .joints_csv import export_csv
from .trc import export_trc

__all__ = ["Run", "read_run", "write_run_dir", "write_rows", "joints_from_poses", "sample_rate",
           "file_rotation", "to_file_frame", "export_trc", "export_c3d",
           "export_bvh", "SKELETON", "read_bvh", "bvh_positions", "BvhFile", "export_csv"]
