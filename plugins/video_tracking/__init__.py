"""Multi-target video tracking with DSmT evidence fusion.

One particle filter per target; each particle is weighted by fusing several image cues
(colour, location, foreground, …) as mass functions over {θ1..θτ, FA} under the tracking
model of :mod:`belief` (SPEC Part D).  OpenCV is used only at the edges: video input and
output, and the background model.
"""
