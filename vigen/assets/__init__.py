"""Image and video assets: built-in banks, procedural stand-ins, loaders for user folders and DMC-GB's palette files.

No machine that builds or tests vigen can download Places365, DAVIS or RealEstate10K: the
defaults here are generated or come with installed packages, and every loader takes a user path
for the real data sets. DMC-GB's colour presets are small and MIT-licensed: they ship with vigen
(:func:`dmcgb_presets`).
"""

from vigen.assets.image_bank import ImageBank
from vigen.assets.palettes import PalettePickleRefused, dmcgb_presets, load_dmcgb_palette
from vigen.assets.procedural import procedural_image, procedural_video
from vigen.assets.video_source import VideoSource

__all__ = ["ImageBank", "PalettePickleRefused", "VideoSource", "dmcgb_presets", "load_dmcgb_palette", "procedural_image", "procedural_video"]
