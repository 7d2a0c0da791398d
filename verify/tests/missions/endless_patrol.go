// The patrol goes on while the battery is at least empty: always.
package Endless

var D1 Quadcopter

func SEQ_Main() {
	D1.Takeoff(2)
	RepeatWhile(D1.Battery() >= 0, SEQ_Patrol)
	D1.Land()
}

func SEQ_Patrol() {
	D1.FlyByX(1)
	D1.FlyByX(-1)
}
