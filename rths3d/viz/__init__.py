"""Live browser view and replay with viser (outside the core: nothing in the core imports it).

``Viewer`` shows a stream of samples (a :class:`rths3d.record.RecordBuffer`) live or a saved
record in replay: the Stewart platform, the sensor, the experimental part, a ghost of the
numerical substructure, the interface wrench, the SSP and time histories, running measures.
"""

from .app import MAX_RATE, RunControl, Viewer
from .playback import Playback
from .stream import buffer_from_record

__all__ = ["MAX_RATE", "Playback", "RunControl", "Viewer", "buffer_from_record", "serve_record"]


def serve_record(path: str, **kwargs: object) -> Viewer:
    """Load a saved record (Parquet/CSV) and start a replay viewer on it (not blocking)."""
    from ..record import Record

    return Viewer(buffer_from_record(Record.load(path)), **kwargs).start()  # type: ignore[arg-type]

