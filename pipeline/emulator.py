"""The emulator's place before pipeline/ was laid out by stage: ``pipeline.emulator`` still
names what ``pipeline.analyse.emulator`` defines, so code that imported ``Emulator`` or caught
``EmulatorError`` from here goes on working. New code takes them from ``pipeline``
(``pipeline.EmulatorError``, ``pipeline.open_emulator``)."""
from .analyse.emulator import Emulator, EmulatorError, Prediction

__all__ = ["Emulator", "EmulatorError", "Prediction"]
