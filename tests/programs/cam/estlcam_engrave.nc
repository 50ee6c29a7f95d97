(Project 004)
(Created by Estlcam version 11 build 11.245)
(Machining time about 00:00:07 hours)

(Required tools:)
(End mill 3mm)
G21
G90
G94
M03 S24000
G00 Z5.0000


(No. 1: Engraving 1)
G00 X0.0000 Y25.4000
G00 Z0.5000
G01 Z0.0000 F600 S24000
G01 Z-1.0000
G01 Y0.0000 F1200
G01 X25.4000
G03 X0.0000 Y25.4000 I-25.3995 J0.0005
G00 Z5.0000
G00 Y0.0000

M05
M30
