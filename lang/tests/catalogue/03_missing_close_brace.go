// The body of SEQ_Fly is not closed before the next function.
package MissingBrace

var Drone1 Quadcopter

func INIT() {
	SEQ_Fly()
}

func SEQ_Fly() {
	Drone1.Takeoff(1.5)
	Drone1.Land()

func SEQ_Unused() {
	Drone1.Disarm()
}
