"""Wiring: functions that build closed-loop Diagrams and return them with their
loggers, the runnable experiment scripts, and diagram-graph rendering."""
