"""Built-in style presets (``<happy>`` ...): named sets of style values in [-3, 3].

The SGToolkit prototype had happy (speed +2.5, acceleration +2.0) and sad (speed -2.5),
chosen from studies of expressive gesture. This toolkit drops acceleration, as the paper's
final prototype did, and expresses the same energy as a wider (happy, angry) or narrower
(sad, calm) gesture space. Angry gestures are fast, large and one-handed; calm ones slow
and a little smaller.
"""

from __future__ import annotations

BUILTIN_PRESETS: dict[str, dict[str, float]] = {
    "happy": {"speed": 2.5, "space": 1.5},
    "sad": {"speed": -2.5, "space": -1.5},
    "angry": {"speed": 2.0, "space": 2.0, "handedness": -1.0},
    "calm": {"speed": -1.5, "space": -0.5},
}
