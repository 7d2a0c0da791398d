// D1 climbs half a metre a round until it is 10 m up, while its battery
// lasts (or the Do stops it): a loop that ends on where the drone is.
package Climb

var D1 Quadcopter

func SEQ_Mission() {
	D1.Arm()
	D1.Takeoff(2)
	DoWhile(D1.Battery() > 20, SEQ_Climb)
	D1.Land()
}

func SEQ_Climb() {
	RepeatUntil(D1.Z() >= 10, SEQ_Up)
}

func SEQ_Up() {
	D1.FlyByZ(0.5)
}
