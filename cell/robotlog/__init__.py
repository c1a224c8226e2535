"""Robot logs in: a cut recorded by a robot (``rostopic echo -p`` dumps, ROS 1 and ROS 2 bags,
MCAP files) turned into the project's cut-test format by a small mapping file
(docs/robot-logs.md).

Modules: :mod:`~cell.robotlog.topics` (one topic of any of those forms, read the same way),
:mod:`~cell.robotlog.bags` (the bag and MCAP readers, the ``ros`` extra),
:mod:`~cell.robotlog.mapping` (the mapping file), :mod:`~cell.robotlog.cutlog` (a log into a
cut test, logs into a set) and :mod:`~cell.robotlog.command` (``musclecell import``).
"""
