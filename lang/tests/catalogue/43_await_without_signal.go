// Waiting for an event that no Signal names would wait forever.
package NoSignal

var D1 Quadcopter
var D2 Quadcopter

func INIT() {
	PAR_Both()
}

func PAR_Both() {
	SEQ_Leader()
	SEQ_Follower()
}

func SEQ_Leader() {
	D1.Takeoff(2)
	Signal("airborne")
}

func SEQ_Follower() {
	Await("airbone")
	Await("landed")
	D2.Takeoff(2)
}
