"""Scenario files of the plugin (entry point ``mjbench.scenarios``): every ``*.toml`` here."""
