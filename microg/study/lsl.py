"""Task and stage events as a Lab Streaming Layer marker stream (optional: ``pip install microg[lsl]``).

Other recordings (EEG, eye tracking, ...) running in LabRecorder get the session's events on the
same clock. Each marker is one JSON string: ``{"kind": "place_lit", "place": 0, ...}``.
"""

from __future__ import annotations

import json


class MarkerOutlet:
    """An LSL outlet of type ``Markers``; call it with an event kind and its data."""

    def __init__(self, name: str = "microg", source_id: str = "microg-markers"):
        try:
            import pylsl
        except ImportError:
            raise ImportError("LSL markers need pylsl: pip install 'microg[lsl]'") from None
        info = pylsl.StreamInfo(name, "Markers", 1, pylsl.IRREGULAR_RATE, "string", source_id)
        self._outlet = pylsl.StreamOutlet(info)

    def __call__(self, kind: str, data: dict) -> None:
        self._outlet.push_sample([json.dumps({"kind": kind, **data}, sort_keys=True)])
