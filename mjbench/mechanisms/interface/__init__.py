"""The mechanism interface, one concern per module; :class:`mjbench.mechanisms.base.Mechanism` joins them."""
