// A Signal that would run once per repetition: directly in a loop body, and
// two calls deep below one.
package SignalLoop

var D1 Quadcopter

func INIT() {
	RepeatFor(3, SEQ_Lap)
	RepeatWhile(D1.Battery() > 30, SEQ_Patrol)
	Await("lap")
	Await("seen")
}

func SEQ_Lap() {
	D1.FlyByX(1)
	Signal("lap")
}

func SEQ_Patrol() {
	SEQ_Look()
}

func SEQ_Look() {
	D1.FlyByY(1)
	Signal("seen")
}
