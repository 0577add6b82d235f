"""Algorithm 1, recording: :meth:`Recorder.step` runs one heartbeat on the robot's own
loop, :meth:`Recorder.run` is the loop itself."""

from beatlog.record.recorder import Recorder, RecordSummary, software_version

__all__ = ["RecordSummary", "Recorder", "software_version"]
