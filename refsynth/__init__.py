"""refsynth: range synthesis from intensity and partial range.

A reference implementation of L. A. Torres-Méndez and G. Dudek,
*Inter-Image Statistics for 3D Environment Modeling*, IJCV 79:137–158 (2008),
doi:10.1007/s11263-007-0108-2.

>>> import refsynth
>>> refsynth.Readings.paper().range_copy   # the readings: refsynth.synthesize(readings=...)
'value'
"""

from refsynth.synthesis import Readings, SynthesisResult, synthesize

__all__ = ["SynthesisResult", "synthesize", "Readings", "__version__"]
__version__ = "0.9.3"
