"""Single-photon LiDAR physics: sensor, photon simulation, reconstruction and SIV.

Public API:

- ``SensorParams``: bin width, pulse sigma, number of bins (and presets).
- ``PhotonScene`` and ``Condition``: what one frame images (depth, reflectance,
  valid) and at which condition (MSPPP, SBR, sensor); every simulation takes both.
- ``simulate_photons``: the measurement model of Algorithm 1 as sparse events.
- ``histogram``: the dense (rows, cols, T) count cube of some events.
- ``reconstruct``: depth / reflectivity / background from events (ML, or SSPI
  with the published weights, ``spl_al.photon.sspi``).
- ``synthesize_variant``: Algorithm 1 end to end (simulate, then reconstruct);
  ``synthesize_variants``: the M variants of every frame of a batch.
- ``load_mat``: import a real capture stored as a sparse pixels x bins matrix.
"""

from spl_al.photon.effects import ObservationModel, observe_photons
from spl_al.photon.events import PhotonEvents, histogram
from spl_al.photon.io import load_mat
from spl_al.photon.reconstruct import METHODS, ML_METHODS, Reconstruction, reconstruct
from spl_al.photon.scene import Condition, PhotonScene
from spl_al.photon.sensor import SPEED_OF_LIGHT_M_PER_S, SensorParams
from spl_al.photon.simulate import simulate_photons
from spl_al.photon.siv import synthesize_variant, synthesize_variants

__all__ = [
    "METHODS",
    "ML_METHODS",
    "SPEED_OF_LIGHT_M_PER_S",
    "Condition",
    "ObservationModel",
    "PhotonEvents",
    "PhotonScene",
    "Reconstruction",
    "SensorParams",
    "histogram",
    "load_mat",
    "observe_photons",
    "reconstruct",
    "simulate_photons",
    "synthesize_variant",
    "synthesize_variants",
]
