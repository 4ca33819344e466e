"""Session 22 (R2): the XML reader's own refusal pickles (docs/interop.md).

``interop.btcpp_xml._Refused`` (a limit the reader meets at a line and column) could
not be read back from a pickle, as a process pool or Dask sends an error: its
``__init__`` takes a line and a column besides its message, and Python's reduction
rebuilt it from the message alone (*missing 2 required positional arguments*).
"""

from __future__ import annotations

import pickle

from pirate_bt.interop.btcpp_xml import _Refused


def test_the_xml_reader_s_refusal_comes_back_from_a_pickle_whole() -> None:
    refused = _Refused("a tag still not closed after 1048576 bytes", 3, 17)
    back = pickle.loads(pickle.dumps(refused))
    assert type(back) is _Refused
    assert (str(back), back.message, back.line, back.column) == (
        "a tag still not closed after 1048576 bytes",
        "a tag still not closed after 1048576 bytes",
        3,
        17,
    )
