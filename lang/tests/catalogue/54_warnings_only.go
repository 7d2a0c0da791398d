// This mission compiles, with warnings: a drone with nothing to do, a
// function never called, an event nobody waits for, a loop that never runs.
package Warnings

var D1 Quadcopter
var D2 Quadcopter

func INIT() {
	D1.Takeoff(1)
	Signal("up")
	RepeatFor(0, SEQ_Lap)
}

func SEQ_Lap() {
	D1.FlyByX(1)
}

func SEQ_Forgotten() {
	D1.Land()
}
