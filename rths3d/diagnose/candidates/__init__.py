"""What a bench's description may have got wrong: candidates that revise the scene itself.

The effects of :mod:`rths3d.effects` are what a bench *adds* to its description; these
candidates are what the description *states wrongly*: the controller's conventions (how a
set-point is held over the interface step, when the channels are sampled, the feed-forward's
difference form, where gravity compensation comes from), the servo's dynamics (where its
lag sits, the lag's and the delay's values, both ways from the statement) and the payload's
inertial parameters. Each is one class in one file behind :class:`DescriptionCandidate`, joined by
:func:`register_description`. A candidate proposes discrete :class:`Revision`\\ s — dotted
scene keys and their new values (``{"controller.hold": "zoh"}``) — and the diagnosis screens
them like effects: each revision replayed once, ranked by the same held-out criterion.
Accepting one rewrites the scene (``--save-scene`` writes it back into ``[platform]``,
``[controller]`` and ``[experiment]``), and the report says which part of the description
changed.
"""

from . import controller, payload, servo  # noqa: E402,F401,I001  (registration)
from .base import (
                   DECISIVE,
                   DESCRIPTIONS,
                   PREFIX,
                   DescriptionCandidate,
                   Revision,
                   contradicted,
                   current,
                   is_revision,
                   register_description,
                   revised_scene,
                   revisions,
)

__all__ = ["DECISIVE", "DESCRIPTIONS", "PREFIX", "DescriptionCandidate", "Revision",
           "contradicted", "current", "is_revision", "register_description", "revised_scene",
           "revisions"]
