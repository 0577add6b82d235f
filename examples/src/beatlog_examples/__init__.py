"""Example robots that ship with beatlog, for the demo, the docs and the tests."""
